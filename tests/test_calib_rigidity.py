"""Board rigidity, epipolar error and the motion clock offset on the twin (the truth is known).

The twin's true cameras pass both checks at the level the 0.2 px corner noise allows; the same
cameras with 2 deg of added relative rotation (about each axis of the front camera) are flagged
by both; a 1 % longer baseline shows as +1 % scale and no epipolar error; a board moving at
about 0.1 m/s filmed with the front frames 0.1 s older than their stamps breaks both checks as
paired by the stamps and passes them once paired at the offset found from the board's motion.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from dempath_calib.board import PAPER_BOARD, BoardSpec
from dempath_calib.camera import StereoCalibration
from dempath_calib.check import load_calibration, pair_streams
from dempath_calib.checkcli import calib_check_main
from dempath_calib.errors import CalibrationFileError
from dempath_calib.pairing import DetectionStream
from dempath_calib.rigidity import board_rigidity, frame_epipolar_errors, fundamental_matrix
from dempath_calib.syncmotion import board_trajectory, motion_offset
from dempath_calib.verify import relative_pose
from dempath_twin.board.recording import calibration_poses, project_views, smooth_poses
from dempath_twin.rig import paper_rig

NOISE_PX = 0.2
BAG = Path(__file__).resolve().parents[1] / 'bags' / 'calib_twin_small'
# With 0.2 px corner noise the true cameras give ~0.22 mm RMS length error and ~0.28 px RMS
# epipolar error; a 2 deg relative rotation gives 0.6-2.2 mm and 4-31 px.
TRUE_MAX = {'rigidity_rms_mm': 0.3, 'epipolar_rms_px': 0.4}
FLAG_MIN = {'rigidity_rms_mm': 0.5, 'epipolar_rms_px': 3.0}


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x ** 2)))


@pytest.fixture(scope='module')
def views() -> np.ndarray:
    """Simultaneous noisy corners of the board lying down and in the shared volume."""
    poses = [p for p in calibration_poses(30, seed=0) if p.phase in ('surface', 'shared')]
    return project_views(poses, NOISE_PX, 0, paper_rig())


def rotated_front(rig: StereoCalibration, axis: list[float], deg: float) -> StereoCalibration:
    """The rig with the front camera turned by ``deg`` about its own centre."""
    rot = cv2.Rodrigues(np.radians(deg) * np.asarray(axis, np.float64))[0]
    return StereoCalibration(rig.side, rig.front.with_pose(rot @ rig.front.R, rot @ rig.front.t))


def test_true_cameras_pass(views: np.ndarray) -> None:
    """All corner pairs within noise of the printed board, epipolar error at the noise."""
    rig = paper_rig()
    rig_check = board_rigidity(rig, views, PAPER_BOARD)
    epi = frame_epipolar_errors(rig, views)
    assert rig_check.n_frames >= 10
    assert rig_check.n_pairs == sum(n * (n - 1) // 2 for n in
                                    np.isfinite(views).all(axis=(1, 3)).sum(1) if n >= 4)
    assert rig_check.rms_mm < TRUE_MAX['rigidity_rms_mm']
    assert abs(rig_check.scale_ppm) < 500
    assert _rms(epi) < TRUE_MAX['epipolar_rms_px']
    assert [b.low_mm for b in rig_check.bins][:3] == pytest.approx([40.4, 80.8, 121.2])


@pytest.mark.parametrize('axis', [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
def test_two_degrees_of_relative_rotation_is_flagged(views: np.ndarray, axis: list[float]) -> None:
    """2 deg added to the relative rotation: both measures well above the true cameras'."""
    rig = paper_rig()
    bad = rotated_front(rig, axis, 2.0)
    good_r, bad_r = (board_rigidity(c, views, PAPER_BOARD) for c in (rig, bad))
    good_e, bad_e = (_rms(frame_epipolar_errors(c, views)) for c in (rig, bad))
    assert bad_r.rms_mm > FLAG_MIN['rigidity_rms_mm']
    assert bad_r.rms_mm > 2.5 * good_r.rms_mm
    assert bad_e > FLAG_MIN['epipolar_rms_px']
    assert bad_e > 10 * good_e


def test_longer_baseline_is_a_scale_not_an_epipolar_error(views: np.ndarray) -> None:
    """Baseline 1 % too long: lengths 1 % too long, epipolar geometry unchanged."""
    rig = paper_rig()
    r, t = relative_pose(rig.side, rig.front)
    longer = StereoCalibration(rig.side, rig.front.with_pose(rig.front.R, rig.front.t + 0.01 * t))
    assert relative_pose(longer.side, longer.front)[0] == pytest.approx(r)
    res = board_rigidity(longer, views, PAPER_BOARD)
    assert res.scale_ppm == pytest.approx(1e4 + board_rigidity(rig, views, PAPER_BOARD).scale_ppm,
                                          abs=50)
    assert res.bins[-1].mean_mm > res.bins[0].mean_mm  # grows with the separation
    assert _rms(frame_epipolar_errors(longer, views)) == pytest.approx(
        _rms(frame_epipolar_errors(rig, views)), rel=1e-6)


def test_fundamental_matrix_matches_opencv() -> None:
    """F from the cameras equals OpenCV's 8-point estimate from exact ideal pixel pairs."""
    rig = paper_rig()
    rng = np.random.default_rng(3)
    xyz = np.column_stack([rng.uniform(-0.2, 0.2, 50), rng.uniform(-0.1, 0.15, 50),
                           rng.uniform(-0.25, 0.25, 50)])
    ideal = [c.undistort_points(c.project(xyz)) for c in rig.cameras]
    f_cv, _ = cv2.findFundamentalMat(ideal[0], ideal[1], cv2.FM_8POINT)
    f_cv /= np.linalg.norm(f_cv)
    f = fundamental_matrix(rig)
    assert min(np.abs(f - f_cv).max(), np.abs(f + f_cv).max()) < 1e-5
    exact = frame_epipolar_errors(rig, np.stack([c.project(xyz) for c in rig.cameras])[None])
    assert exact.max() < 1e-6


def _moving_streams(delay_s: float) -> tuple[DetectionStream, DetectionStream]:
    """The board moved smoothly (~0.1 m/s) at ~6 FPS; front frames stamped ``delay_s`` late."""
    keys = [p for p in calibration_poses(30, seed=0) if p.phase == 'shared'][:6]
    poses = smooth_poses(keys, 300)  # 10 ms apart
    corners = project_views(poses, NOISE_PX, 1, paper_rig())
    streams = (DetectionStream(PAPER_BOARD.n_corners), DetectionStream(PAPER_BOARD.n_corners))
    for cam, first in ((0, 0), (1, 10)):
        for i in range(first, len(poses), 16):
            if np.isfinite(corners[i, cam]).all(1).sum() >= 6:
                streams[cam].add(0.01 * i + (delay_s if cam else 0.0), corners[i, cam])
    return streams


def test_motion_offset_and_synchronised_pairs() -> None:
    """Offset found from the motion alone; both checks pass only on truly simultaneous pairs."""
    rig = paper_rig()
    streams = _moving_streams(0.1)
    (ts, cs), (tf, cf) = (s.arrays() for s in streams)
    found = motion_offset(ts, board_trajectory(cs, rig.side, PAPER_BOARD), tf,
                          board_trajectory(cf, rig.front, PAPER_BOARD), 0.5)
    assert found.offset_s == pytest.approx(-0.1, abs=0.005)
    assert found.rms_zero_mm > 5 * found.rms_mm
    stamped, synced = (pair_streams(streams, off) for off in (0.0, found.offset_s))
    assert board_rigidity(rig, stamped, PAPER_BOARD).rms_mm > FLAG_MIN['rigidity_rms_mm']
    assert _rms(frame_epipolar_errors(rig, stamped)) > FLAG_MIN['epipolar_rms_px']
    # linear interpolation of the moving front corners adds a little to the noise
    assert board_rigidity(rig, synced, PAPER_BOARD).rms_mm < 1.5 * TRUE_MAX['rigidity_rms_mm']
    assert _rms(frame_epipolar_errors(rig, synced)) < 1.5 * TRUE_MAX['epipolar_rms_px']


def _write_caliscope(path: Path, rig: StereoCalibration) -> None:
    """The rig in Caliscope's camera_array.toml layout."""
    lines = []
    for i, cam in enumerate(rig.cameras):
        lines += [f'[cameras.{i}]', f'cam_id = {i}', f'size = [{cam.width}, {cam.height}]',
                  f'matrix = {cam.K.tolist()}', f'distortions = {cam.dist.tolist()}',
                  f'rotation = {cam.R.tolist()}', f'translation = {cam.t.tolist()}', '']
    path.write_text('\n'.join(lines))


def test_load_calibration(tmp_path: Path) -> None:
    """Folder, stereo YAML and Caliscope TOML read alike; bad files give one clear error."""
    rig = paper_rig()
    rig.save(tmp_path / 'stereo.yaml')
    _write_caliscope(tmp_path / 'camera_array.toml', rig)
    for p in (tmp_path, tmp_path / 'stereo.yaml', tmp_path / 'camera_array.toml'):
        got = load_calibration(p)
        for a, b in zip(got.cameras, rig.cameras, strict=True):
            assert np.allclose(a.K, b.K) and np.allclose(a.R, b.R)
    (tmp_path / 'bad.toml').write_text('[cameras.0]\nmatrix = 3\n')
    with pytest.raises(CalibrationFileError, match=r'bad\.toml.*not a Caliscope camera array'):
        load_calibration(tmp_path / 'bad.toml')
    with pytest.raises(CalibrationFileError, match='not found'):
        load_calibration(tmp_path / 'missing')


def test_calib_check_cli_on_twin_bag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``dempath calib-check`` on the bundled twin bag: the true cameras pass, a turned one not."""
    truth = json.loads(BAG.with_name(BAG.name + '.truth.json').read_text())
    rig = StereoCalibration.from_dict(truth['rig'])
    board = BoardSpec(**{k: v for k, v in truth['board'].items() if k in ('columns', 'rows',
                                                                        'square_m', 'marker_m',
                                                                        'dictionary')})
    assert board.n_corners == PAPER_BOARD.n_corners
    rig.save(tmp_path / 'true' / 'stereo.yaml')
    rotated_front(rig, [0, 1.0, 0], 2.0).save(tmp_path / 'turned.yaml')
    argv = [str(tmp_path / 'true'), str(BAG), '--against', str(tmp_path / 'turned.yaml'),
            '--offset', '0', '--json']
    assert calib_check_main(argv) == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    true_c, turned = out['pairings']['given']['checks']
    assert true_c['rigidity']['frames'] >= 5
    assert true_c['rigidity']['rms_mm'] < TRUE_MAX['rigidity_rms_mm']
    assert true_c['epipolar']['rms_px'] < 2 * TRUE_MAX['epipolar_rms_px']
    assert turned['rigidity']['rms_mm'] > FLAG_MIN['rigidity_rms_mm']
    assert turned['epipolar']['rms_px'] > FLAG_MIN['epipolar_rms_px']
    assert calib_check_main([str(tmp_path / 'nowhere'), str(BAG)]) == 1
    assert capsys.readouterr().err.startswith('error: ')
