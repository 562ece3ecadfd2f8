"""`dempath calibrate` on the twin's calibration bag recovers the true cameras (issue #5).

Tolerances (30 rendered views per camera, JPEG, blur, noise, lighting, occlusion):

| quantity | tolerance |
| --- | --- |
| fx, fy | within 0.5 % |
| cx, cy | within 3 px |
| camera orientation | within 0.3 deg |
| camera centre | within 3 mm |
| neighbouring-corner distance, mean | within 0.1 mm of 40.4 mm |
| neighbouring-corner distance, SD | below 0.5 mm (paper: about 1 mm) |
| reprojection RMSE | below 0.3 px per camera |
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dempath_calib.camera import StereoCalibration
from dempath_calib.camerainfo import read_camera_info
from dempath_calib.cli import calibrate_main
from dempath_calib.pointset import load_point_set
from dempath_calib.verify import compare_to_truth
from dempath_twin.board.bag import truth_path, write_calibration_bag
from dempath_twin.cli import rig_main
from dempath_twin.rig import paper_rig

TOL = {'f_rel_pct': 0.5, 'c_px': 3.0, 'rotation_deg': 0.3, 'center_mm': 3.0,
       'spacing_mean_mm': 0.1, 'spacing_sd_mm': 0.5, 'rmse_px': 0.3}


@pytest.fixture(scope='module')
def twin_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 30-view twin calibration bag (JPEG) in a temporary folder."""
    return write_calibration_bag(tmp_path_factory.mktemp('twin') / 'calib_twin', n_views=30,
                                 seed=0)


@pytest.fixture(scope='module')
def calibrated(twin_bag: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Output folder of `dempath calibrate` on the twin bag."""
    out = tmp_path_factory.mktemp('out')
    assert calibrate_main([str(twin_bag), '--out', str(out)]) == 0
    return out


def test_truth_written_beside_bag(twin_bag: Path) -> None:
    """The bag has its truth JSON (cameras, board, 30 poses) beside it."""
    truth = json.loads(truth_path(twin_bag).read_text())
    assert len(truth['poses']) == 30 and truth['board']['square_m'] == 0.0404
    assert StereoCalibration.from_dict(truth['rig']).side.K[0, 0] == 914.24


def test_calibration_recovers_truth(calibrated: Path) -> None:
    """Recovered intrinsics, poses and corner spacing are within the table's tolerances."""
    calib = StereoCalibration.load(calibrated / 'stereo.yaml')
    err = compare_to_truth(calib, paper_rig())
    report = json.loads((calibrated / 'report.json').read_text())
    print('\ntwin errors:', json.dumps(err, default=float), '\nreport:',
          json.dumps({k: report[k] for k in ('rmse_px', 'views', 'corner_spacing')}))
    for cam in ('side', 'front'):
        e = err[cam]
        assert abs(e['fx_rel_pct']) < TOL['f_rel_pct'] and abs(e['fy_rel_pct']) < TOL['f_rel_pct']
        assert abs(e['cx_px']) < TOL['c_px'] and abs(e['cy_px']) < TOL['c_px'], e
        assert e['rotation_deg'] < TOL['rotation_deg'], e
        assert e['center_mm'] < TOL['center_mm'], e
        assert report['rmse_px'][cam] < TOL['rmse_px']
    spacing = report['corner_spacing']
    assert abs(spacing['mean_mm'] - 40.4) < TOL['spacing_mean_mm']
    assert spacing['sd_mm'] < TOL['spacing_sd_mm']


def test_output_files(calibrated: Path) -> None:
    """camera_info YAMLs match the stereo file; the point set pairs pixels with world points."""
    calib = StereoCalibration.load(calibrated / 'stereo.yaml')
    for cam in calib.cameras:
        info = read_camera_info(calibrated / f'{cam.name}.yaml')
        np.testing.assert_allclose(info.K, cam.K)
    ps = load_point_set(calibrated / 'point_set.npz')
    csv = load_point_set(calibrated / 'point_set.csv')
    assert len(ps) == len(csv) > 200
    uv = calib.side.project(ps.xyz)
    assert np.median(np.linalg.norm(uv - ps.pixels[:, :2], axis=1)) < 0.5


def test_cli_bad_inputs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Missing input or a bag without image topics: one error line and exit code 1."""
    assert calibrate_main([str(tmp_path / 'nothing'), '--out', str(tmp_path / 'o')]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('error: ') and 'not found' in err[0]
    assert rig_main([str(tmp_path / 'rig_bag'), '--views', '0']) == 1
    assert 'must be >= 1' in capsys.readouterr().err
