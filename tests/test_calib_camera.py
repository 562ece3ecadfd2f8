"""Camera model, stereo YAML, camera_info YAML and point-set files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath_calib.camera import CameraModel, StereoCalibration
from dempath_calib.camerainfo import read_camera_info, write_camera_info
from dempath_calib.errors import CalibrationFileError
from dempath_calib.pointset import load_point_set, make_point_set, save_point_set
from dempath_twin.rig import WORKING_VOLUME, paper_rig, sample_working_volume

pytestmark = pytest.mark.usefixtures('strict_numpy')  # as the dempath_calib tests ran


def test_rig_sees_working_volume() -> None:
    """Both twin cameras see every corner of the working volume, about 0.6-1.2 m away."""
    rig = paper_rig()
    lo, hi = WORKING_VOLUME
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    for cam in rig.cameras:
        uv = cam.project(corners)
        assert np.all((uv >= 0) & (uv < [cam.width, cam.height]))
        dist = np.linalg.norm(corners - cam.center, axis=1)
        assert dist.min() > 0.6 and dist.max() < 1.25  # "about 0.6-1.2 m" (issue #5)
    assert rig.side.K[0, 0] == 914.24 and rig.front.K[1, 2] == 555.56


def test_undistort_inverts_project() -> None:
    """undistort_points(project(X)) equals the ideal pinhole pixel to 1e-6 px."""
    rng = np.random.default_rng(0)
    for cam in paper_rig().cameras:
        xyz = sample_working_volume(200, rng)
        pc = cam.to_camera(xyz)
        ideal = pc[:, :2] / pc[:, 2:] * np.diag(cam.K)[:2] + cam.K[:2, 2]
        assert np.abs(cam.undistort_points(cam.project(xyz)) - ideal).max() < 1e-6


def test_stereo_yaml_round_trip(tmp_path: Path) -> None:
    """A StereoCalibration saved as YAML loads back identical."""
    rig = paper_rig()
    back = StereoCalibration.load(rig.save(tmp_path / 'stereo.yaml'))
    for a, b in zip(rig.cameras, back.cameras, strict=True):
        assert a.name == b.name
        for f in ('K', 'dist', 'R', 't'):
            np.testing.assert_allclose(getattr(a, f), getattr(b, f), atol=1e-12)


@pytest.mark.parametrize('content', [None, 'side: [1, 2', 'side: {name: x}\nfront: 3\n'])
def test_bad_stereo_file(tmp_path: Path, content: str | None) -> None:
    """A missing or corrupt stereo file gives one CalibrationFileError naming the file."""
    path = tmp_path / 'stereo.yaml'
    if content is not None:
        path.write_text(content)
    with pytest.raises(CalibrationFileError, match=r'stereo\.yaml'):
        StereoCalibration.load(path)


def test_camera_info_round_trip(tmp_path: Path) -> None:
    """camera_info YAML has the camera_calibration_parsers keys and reads back K and D."""
    cam = paper_rig().front
    path = write_camera_info(tmp_path / 'cam_front.yaml', cam)
    text = path.read_text()
    for key in ('image_width', 'image_height', 'camera_name', 'camera_matrix',
                'distortion_model', 'distortion_coefficients', 'rectification_matrix',
                'projection_matrix'):
        assert f'{key}:' in text
    back = read_camera_info(path)
    np.testing.assert_allclose(back.K, cam.K)
    np.testing.assert_allclose(back.dist, cam.dist)
    (tmp_path / 'bad.yaml').write_text('camera_matrix: {rows: 3}\n')
    with pytest.raises(CalibrationFileError, match=r'bad\.yaml'):
        read_camera_info(tmp_path / 'bad.yaml')


@pytest.mark.parametrize('suffix', ['npz', 'csv'])
def test_point_set_round_trip(tmp_path: Path, suffix: str) -> None:
    """Point sets survive .npz and .csv (pixels to 1e-6 px, xyz to 1e-9 m)."""
    rng = np.random.default_rng(1)
    ps = make_point_set(rng.random((50, 4)) * 1000, rng.random((50, 3)), np.arange(50) // 7,
                        np.arange(50) % 24)
    back = load_point_set(save_point_set(tmp_path / f'ps.{suffix}', ps))
    np.testing.assert_allclose(back.pixels, ps.pixels, atol=1e-6)
    np.testing.assert_allclose(back.xyz, ps.xyz, atol=1e-9)
    np.testing.assert_array_equal(back.view, ps.view)
    np.testing.assert_array_equal(back.corner_id, ps.corner_id)


def test_bad_point_set_files(tmp_path: Path) -> None:
    """Missing, truncated and wrong-header point sets give CalibrationFileError."""
    with pytest.raises(CalibrationFileError, match='not found'):
        load_point_set(tmp_path / 'none.npz')
    (tmp_path / 'cut.npz').write_bytes(b'PK\x03\x04garbage')
    with pytest.raises(CalibrationFileError, match=r'cut\.npz'):
        load_point_set(tmp_path / 'cut.npz')
    (tmp_path / 'bad.csv').write_text('a,b\n1,2\n')
    with pytest.raises(CalibrationFileError, match=r'bad\.csv'):
        load_point_set(tmp_path / 'bad.csv')


def test_camera_rejects_bad_rotation() -> None:
    """A CameraModel with a non-rotation R is refused with the field named."""
    with pytest.raises(ValueError, match='R'):
        CameraModel('x', 10, 10, np.eye(3), np.zeros(5), 2 * np.eye(3), np.zeros(3))
