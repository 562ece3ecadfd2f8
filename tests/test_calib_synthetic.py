"""Calibration core on projected twin views (no rendering): truth recovery, bad inputs, pairing."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_calib.board import PAPER_BOARD
from dempath_calib.calibrator import (
    CalibrationConfig,
    CalibrationResult,
    Calibrator,
    calibrate_detections,
)
from dempath_calib.collect import ViewCollector
from dempath_calib.errors import DegenerateViewsError, NotEnoughViewsError
from dempath_calib.intrinsics import calibrate_intrinsics
from dempath_calib.pairing import DetectionStream, pair_frames
from dempath_calib.verify import compare_to_truth
from dempath_twin.board.recording import calibration_poses, project_views, smooth_poses
from dempath_twin.rig import paper_rig

pytestmark = pytest.mark.usefixtures('strict_numpy')  # as the dempath_calib tests ran

# Tolerances with 0.2 px corner noise and 40 views (projected, not rendered).
# The residual RMSE must match the injected noise, 0.2 * sqrt(2) = 0.283 px, within 0.04 px.
TOL = {'f_rel_pct': 0.2, 'c_px': 1.5, 'rotation_deg': 0.1, 'center_mm': 1.5,
       'spacing_mean_mm': 0.05, 'rmse_noise_px': 0.04}
NOISE_PX = 0.2


@pytest.fixture(scope='module')
def views() -> tuple[np.ndarray, np.ndarray]:
    """40 projected views with 0.2 px noise and their stamps."""
    corners = project_views(calibration_poses(40, seed=5), noise_px=NOISE_PX, seed=5)
    return corners, np.arange(len(corners)) * 0.5


@pytest.fixture(scope='module')
def batch(views: tuple[np.ndarray, np.ndarray]) -> CalibrationResult:
    """The batch calibration of the projected views."""
    return calibrate_detections(*views, CalibrationConfig())


def test_recovers_twin_truth(batch: CalibrationResult) -> None:
    """Intrinsics, poses and corner spacing come back within the TOL table."""
    res = batch
    err = compare_to_truth(res.calibration, paper_rig())
    for cam in ('side', 'front'):
        e = err[cam]
        assert abs(e['fx_rel_pct']) < TOL['f_rel_pct'] and abs(e['fy_rel_pct']) < TOL['f_rel_pct']
        assert abs(e['cx_px']) < TOL['c_px'] and abs(e['cy_px']) < TOL['c_px'], e
        assert e['rotation_deg'] < TOL['rotation_deg'] and e['center_mm'] < TOL['center_mm'], e
        assert abs(res.report['rmse_px'][cam] - NOISE_PX * np.sqrt(2)) < TOL['rmse_noise_px']
    spacing = res.report['corner_spacing']
    assert abs(spacing['mean_mm'] - 40.4) < TOL['spacing_mean_mm']
    assert list(res.world_frames) == [0, 1, 2]
    ps = res.point_set
    assert len(ps) == res.report['point_set_size'] > 300
    truth = calibration_poses(40, seed=5)
    obj = PAPER_BOARD.object_points()
    xyz_true = np.array([obj[c] @ truth[v].rot.T + truth[v].t
                         for v, c in zip(ps.view, ps.corner_id, strict=True)])
    assert np.abs(ps.xyz - xyz_true).max() < 0.003  # m


def test_too_few_views_says_how_many_and_where(views: tuple[np.ndarray, np.ndarray]) -> None:
    """Five views: the error asks for 3 more and names uncovered image parts."""
    corners, _ = views
    few = corners[3:8, 0]
    with pytest.raises(NotEnoughViewsError, match=r'5 usable .* need 8: 3 more; no corners yet '
                                                  r'in the .*(left|right|top|bottom)'):
        calibrate_intrinsics('cam_side', few, PAPER_BOARD, (1920, 1080))


def test_degenerate_views_refused(views: tuple[np.ndarray, np.ndarray]) -> None:
    """Ten copies of one pose (plus tiny noise) are refused, not calibrated."""
    corners, _ = views
    rng = np.random.default_rng(0)
    same = np.repeat(corners[5:6, 0], 10, axis=0) + 0.1 * rng.standard_normal((10, 24, 2))
    with pytest.raises(DegenerateViewsError, match='same pose'):
        calibrate_intrinsics('cam_side', same, PAPER_BOARD, (1920, 1080))


def test_frames_without_board_are_skipped_and_counted() -> None:
    """Blank images add no view and are counted as skipped."""
    cal = Calibrator()
    blank = np.full((1080, 1920), 128, np.uint8)
    for i in range(3):
        cal.add_image(0, i * 0.1, blank)
    cal.add_image(1, 0.0, blank)
    p = cal.progress()
    assert p.frames == (3, 1) and p.views == (0, 0) and p.skipped == (3, 1)


def test_streaming_equals_batch(views: tuple[np.ndarray, np.ndarray],
                                batch: CalibrationResult) -> None:
    """Calibrator fed detection by detection gives the batch result."""
    corners, stamps = views
    cal = Calibrator()
    for i, t in enumerate(stamps):
        for c in range(2):
            cal.add_detection(c, t, corners[i, c])
    streamed = cal.solve().calibration
    for a, b in zip(streamed.cameras, batch.calibration.cameras, strict=True):
        np.testing.assert_allclose(a.K, b.K, rtol=1e-6)
        np.testing.assert_allclose(a.t, b.t, atol=1e-7)


def test_pairing_interpolates_and_estimates_offset() -> None:
    """A front clock late by 0.07 s (frames at 10 Hz): offset found within 10 ms."""
    keys = calibration_poses(9, seed=8, n_surface=0, shared_fraction=1.0)
    poses = smooth_poses(keys, 8)
    dense = project_views(poses, noise_px=0.1, seed=8)
    t = np.arange(len(poses)) * 0.05  # poses every 50 ms; each camera samples every 100 ms
    side, front = DetectionStream(24), DetectionStream(24)
    for i in range(0, len(poses), 2):
        side.add(t[i], dense[i, 0])
    for i in range(1, len(poses), 2):  # front exposes 50 ms later, its clock reads 70 ms more
        front.add(t[i] + 0.07, dense[i, 1])
    _, paired = pair_frames(side, front, offset_s=-0.07)
    ok = ~np.isnan(paired[:, 1, :, 0]) & ~np.isnan(paired[:, 0, :, 0])
    assert ok.sum() > 100
    cal = Calibrator(CalibrationConfig(offset_s=None, max_offset_s=0.1, world='side',
                                       min_views=6))
    for c, stream in enumerate((side, front)):
        for stamp, det in zip(stream.stamps, stream.corners, strict=True):
            cal.add_detection(c, stamp, det)
    res = cal.solve()
    assert abs(res.report['offset_s'] - (-0.07)) < 0.01, res.report['offset_s']


def test_collector_drops_oldest_and_counts() -> None:
    """The size-1 queue keeps the newest image: processed + dropped = sent, newest processed."""
    cal = Calibrator()
    col = ViewCollector(cal)
    blank = np.zeros((216, 384), np.uint8)
    try:
        for i in range(6):
            col.put(1, float(i), blank)
        assert col.drain(10.0)
    finally:
        col.close()
    assert cal.progress().frames[1] + col.dropped[1] == 6
    assert cal.progress().frames[1] >= 1


def test_synthetic_point_set_noise() -> None:
    """The paper-size point set has the asked size and exactly the asked pixel noise."""
    from dempath_twin.board.recording import synthetic_point_set
    ps = synthetic_point_set(5000, noise_px=0.2, seed=2)
    rig = paper_rig()
    assert len(ps) == 5000 and len(np.unique(ps.view)) > 200
    resid = np.hstack([rig.side.project(ps.xyz), rig.front.project(ps.xyz)]) - ps.pixels
    assert abs(resid.std() - 0.2) < 0.01 and abs(resid.mean()) < 0.01
    lo, hi = ps.xyz.min(0), ps.xyz.max(0)
    assert np.all(hi - lo > 0.15)  # spread through the shared volume [m]
