"""Calibration (dempath_calib) feeding reconstruction (dempath_recon) on the digital twin."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_calib.board import PAPER_BOARD
from dempath_calib.calibrator import CalibrationConfig, calibrate_detections
from dempath_recon.methods.residual import ResidualReconstructor
from dempath_recon.methods.triangulate import DLTTriangulator
from dempath_twin.board.recording import calibration_poses, synthetic_point_set
from dempath_twin.rig import paper_rig


@pytest.fixture(scope='module')
def calibrated():
    """Calibrate from 40 twin views: true corners projected with 0.2 px noise (no rendering)."""
    rig, rng = paper_rig(), np.random.default_rng(11)
    poses = calibration_poses(40, seed=11)
    obj = PAPER_BOARD.object_points()
    corners = np.full((len(poses), 2, len(obj), 2), np.nan)
    for i, pose in enumerate(poses):
        xyz = obj @ pose.rot.T + pose.t
        for c, cam in enumerate(rig.cameras):
            uv = cam.project(xyz)
            inside = (uv[:, 0] >= 0) & (uv[:, 0] < cam.width) & (uv[:, 1] >= 0) \
                & (uv[:, 1] < cam.height)
            corners[i, c, inside] = uv[inside] + rng.normal(0.0, 0.2, (inside.sum(), 2))
    return calibrate_detections(corners, 0.02 * np.arange(len(poses)), CalibrationConfig())


def test_triangulation_with_estimated_calibration(calibrated) -> None:
    """DLT with the calibration dempath_calib estimated: held-out mean < 0.6 mm, max < 3 mm."""
    truth = synthetic_point_set(3000, noise_px=0.2, seed=12)
    tri = DLTTriangulator().fit(calibration=calibrated.calibration)
    err = np.linalg.norm(tri.predict(truth.pixels) - truth.xyz, axis=1)
    assert err.mean() < 0.6e-3 and err.max() < 3e-3, (err.mean(), err.max())


def test_residual_trained_on_the_calibration_point_set(calibrated) -> None:
    """The residual model trained on the calibration's own point set is no worse than DLT."""
    truth = synthetic_point_set(3000, noise_px=0.2, seed=13)
    ps = calibrated.point_set
    tri = DLTTriangulator().fit(calibration=calibrated.calibration)
    res = ResidualReconstructor(epochs=30, random_state=0, device='cpu').fit(
        ps.pixels, ps.xyz, calibration=calibrated.calibration)
    e_tri = np.linalg.norm(tri.predict(truth.pixels) - truth.xyz, axis=1).mean()
    e_res = np.linalg.norm(res.predict(truth.pixels) - truth.xyz, axis=1).mean()
    assert e_res < e_tri * 1.1, (e_res, e_tri)
