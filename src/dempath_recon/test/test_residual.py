"""Triangulation with a learned residual: it removes a calibration bias the DLT cannot."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_recon.methods.residual import ResidualReconstructor
from dempath_recon.methods.triangulate import DLTTriangulator


@pytest.fixture(scope='module')
def biased(rig):
    """The true cameras with a 1% focal-length error and a wrong k1 on the front camera."""
    front = rig.front
    k = front.K.copy()
    k[0, 0] *= 1.01
    k[1, 1] *= 1.01
    dist = front.dist.copy()
    dist[0] += 0.02
    from dempath_calib.camera import CameraModel
    wrong = CameraModel(front.name, front.width, front.height, k, dist, front.R, front.t)
    return (rig.side, wrong)


def test_residual_network_removes_calibration_bias(biased, points) -> None:
    """On a biased calibration the residual model cuts the held-out mean error at least 3x."""
    train, test = slice(0, 3000), slice(3000, None)
    dlt = DLTTriangulator().fit(calibration=biased)
    res = ResidualReconstructor(epochs=60, patience=8, random_state=0, device='cpu').fit(
        points.pixels[train], points.xyz[train], calibration=biased)
    e_dlt = np.linalg.norm(dlt.predict(points.pixels[test]) - points.xyz[test], axis=1).mean()
    e_res = np.linalg.norm(res.predict(points.pixels[test]) - points.xyz[test], axis=1).mean()
    assert e_res < e_dlt / 3.0, (e_res, e_dlt)


def test_residual_save_load_round_trip(rig, points, tmp_path) -> None:
    """The saved residual model (cameras + network) predicts the same points after loading."""
    est = ResidualReconstructor(epochs=3, random_state=0, device='cpu').fit(
        points.pixels[:1000], points.xyz[:1000], calibration=rig)
    loaded = ResidualReconstructor.load(est.save(tmp_path / 'res.pt'), device='cpu')
    assert np.allclose(loaded.predict(points.pixels), est.predict(points.pixels), atol=1e-12)
