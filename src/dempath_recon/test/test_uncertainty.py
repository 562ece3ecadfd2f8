"""Propagated pixel noise: the stated 1-sigma covers about 68% of the actual 3D errors."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_recon.methods.triangulate import DLTTriangulator
from dempath_recon.methods.uncertainty import (
    CLICK_SIGMA_PX,
    coverage,
    jacobian_covariance,
    monte_carlo_covariance,
    propagate,
    sigma_from_covariance,
)
from dempath_twin.rig import sample_working_volume


@pytest.fixture(scope='module')
def clicked(rig):
    """5,000 true points and their pixels with the paper's clicking noise (2.36, 2.75) px."""
    rng = np.random.default_rng(7)
    xyz = sample_working_volume(5000, rng)
    pixels = np.hstack([c.project(xyz) for c in rig.cameras])
    noise = rng.normal(size=pixels.shape) * np.tile(CLICK_SIGMA_PX, 2)
    return xyz, pixels + noise


@pytest.mark.parametrize('refine', [False, True])
def test_analytic_sigma_covers_68_percent(rig, clicked, refine: bool) -> None:
    """Per axis and Mahalanobis, 66-71% of errors lie inside the propagated 1-sigma."""
    xyz, pixels = clicked
    tri = DLTTriangulator(refine=refine).fit(calibration=rig)
    cov = propagate(tri, pixels)
    cover = coverage(tri.predict(pixels) - xyz, cov)
    assert cover['n'] == len(xyz)
    for share in [*cover['per_axis'], cover['mahalanobis']]:
        assert 0.66 < share < 0.71, cover


def test_generic_jacobian_equals_analytic(rig, clicked) -> None:
    """Differencing predict() gives the analytic triangulation sigma within 3%."""
    _, pixels = clicked
    tri = DLTTriangulator(refine=True).fit(calibration=rig)
    generic = sigma_from_covariance(jacobian_covariance(tri, pixels[:300]))
    analytic = sigma_from_covariance(propagate(tri, pixels[:300]))
    assert np.abs(generic / analytic - 1).max() < 0.03


def test_monte_carlo_agrees_with_first_order(rig, clicked) -> None:
    """Monte Carlo sigma (400 draws) matches first order within 15% per point and 3% median."""
    _, pixels = clicked
    tri = DLTTriangulator(refine=False).fit(calibration=rig)
    mc = sigma_from_covariance(monte_carlo_covariance(tri, pixels[:100], CLICK_SIGMA_PX, 400,
                                                      np.random.default_rng(8)))
    ratio = mc / sigma_from_covariance(propagate(tri, pixels[:100]))
    assert np.abs(ratio - 1).max() < 0.15
    assert np.abs(np.median(ratio, axis=0) - 1).max() < 0.03
