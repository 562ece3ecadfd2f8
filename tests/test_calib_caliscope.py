"""Calibrate the real two-webcam ChArUco recording and compare with Caliscope's own result.

Data: ../shared/data/caliscope_charuco_2cam (Caliscope 0.11.5 test session, BSD-2): 4x5 board,
DICT_4X4_1000, 54 mm squares, printed inverted; 1280x720 webcams, 111 frames each at ~6 FPS,
not hardware-synchronised. Caliscope's RMSE: 0.541 px (cam 0) and 0.401 px (cam 1).
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from dempath_calib.camera import CameraModel, StereoCalibration
from dempath_calib.cli import calibrate_main
from dempath_calib.verify import relative_pose, rotation_angle_deg

DATA = Path(__file__).resolve().parents[2] / 'shared' / 'data' / 'caliscope_charuco_2cam'
CALISCOPE_RMSE = {'side': 0.541, 'front': 0.401}  # cam 0, cam 1 (camera_array.toml)
# Tolerances against Caliscope (a reference, not ground truth) and the printed 54 mm squares.
TOL = {'ba_rmse_px': 0.5, 'rotation_deg': 6.0, 'baseline_rel': 0.05, 'spacing_mean_mm': 0.2,
       'spacing_rms_mm': 0.5}

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not DATA.is_dir(), reason=f'{DATA} not present')]


def caliscope_cameras() -> tuple[CameraModel, CameraModel]:
    """Caliscope's cameras 0 and 1 from camera_array.toml."""
    cams = tomllib.loads((DATA / 'camera_array.toml').read_text())['cameras']
    return tuple(CameraModel(f'cam_{i}', 1280, 720, np.array(cams[str(i)]['matrix']),
                             np.array(cams[str(i)]['distortions']),
                             np.array(cams[str(i)]['rotation']),
                             np.array(cams[str(i)]['translation'])) for i in (0, 1))


@pytest.fixture(scope='module')
def result(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """`dempath calibrate` on the two videos, clock offset estimated."""
    out = tmp_path_factory.mktemp('caliscope')
    ext = DATA / 'calibration' / 'extrinsic'
    argv = [str(ext / 'cam_0.mp4'), str(ext / 'cam_1.mp4'), '--out', str(out),
            '--board', 'caliscope', '--world', 'side', '--offset', 'auto',
            '--max-offset', '0.25', '--timestamps', str(ext / 'timestamps.csv')]
    assert calibrate_main(argv) == 0
    return out


def test_against_caliscope(result: Path) -> None:
    """RMSE at or below Caliscope's, relative pose close to Caliscope's, 54 mm squares kept."""
    rep = json.loads((result / 'report.json').read_text())
    ours = StereoCalibration.load(result / 'stereo.yaml')
    r_c, t_c = relative_pose(*caliscope_cameras())
    r_o, t_o = relative_pose(*ours.cameras)
    pose = {'rotation_diff_deg': rotation_angle_deg(r_o, r_c),
            'baseline_ours_m': float(np.linalg.norm(t_o)),
            'baseline_caliscope_m': float(np.linalg.norm(t_c)),
            'direction_diff_deg': float(np.degrees(np.arccos(
                np.clip(t_o @ t_c / np.linalg.norm(t_o) / np.linalg.norm(t_c), -1, 1))))}
    print('\ncaliscope comparison:', json.dumps({
        'intrinsic_rmse_px': rep['intrinsic_rmse_px'], 'bundle_rmse_px': rep['rmse_px'],
        'caliscope_rmse_px': CALISCOPE_RMSE, 'offset_s': rep['offset_s'],
        'relative_pose': pose, 'corner_spacing': rep['corner_spacing']}))
    for cam in ('side', 'front'):
        assert rep['intrinsic_rmse_px'][cam] <= CALISCOPE_RMSE[cam]
        assert rep['rmse_px'][cam] < TOL['ba_rmse_px']
    assert pose['rotation_diff_deg'] < TOL['rotation_deg']
    assert abs(pose['baseline_ours_m'] / pose['baseline_caliscope_m'] - 1) < TOL['baseline_rel']
    spacing = rep['corner_spacing']
    assert abs(spacing['mean_mm'] - 54.0) < TOL['spacing_mean_mm']
    assert spacing['rms_error_mm'] < TOL['spacing_rms_mm']
