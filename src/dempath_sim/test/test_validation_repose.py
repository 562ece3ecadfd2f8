"""Angle-of-repose measurement on synthetic piles of known slope, and the case set-up."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dempath_sim.validation.repose import ReposeCase, repose_angles


def _cone(angle_deg: float, radius: float = 0.002, height: float = 0.05) -> np.ndarray:
    """Sphere centres (n, 3) [m] on a cubic lattice inside a cone of the given slope."""
    a = 2 * radius
    base = height / math.tan(math.radians(angle_deg))
    g = np.arange(-base, base + a, a)
    y = np.arange(radius, height, a)
    pts = np.stack(np.meshgrid(g, y, g, indexing='ij'), axis=-1).reshape(-1, 3)
    r = np.hypot(pts[:, 0], pts[:, 2])
    return pts[pts[:, 1] + radius <= height - r * math.tan(math.radians(angle_deg)) + a]


@pytest.mark.parametrize('angle', [20.0, 30.0, 38.0])
def test_cone_angle_is_recovered(angle: float) -> None:
    """A lattice cone of slope 20-38 deg reads back within 2 deg from the base and the top."""
    pos = _cone(angle)
    res = repose_angles('synthetic', pos, np.full(len(pos), 0.002))
    assert res.base_deg == pytest.approx(angle, abs=2.0)
    assert res.top_deg == pytest.approx(angle, abs=2.0)


def test_case_fills_the_tube_without_overlaps() -> None:
    """The initial lattice lies inside the tube, spheres do not overlap, sizes within +-10 %."""
    case = ReposeCase()
    pos, radii = case.particles()
    assert np.hypot(pos[:, 0], pos[:, 2]).max() + radii.max() < case.diameter / 2
    from scipy.spatial import cKDTree

    pairs = cKDTree(pos).query_pairs(2 * radii.max(), output_type='ndarray')
    gaps = np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1) - radii[pairs].sum(1)
    assert gaps.min() > 0.0
    assert radii.min() >= 0.9 * case.particle_diameter / 2
    assert radii.max() <= 1.1 * case.particle_diameter / 2
    tube = case.tube()
    assert np.allclose(np.hypot(tube[..., 0], tube[..., 2]), case.diameter / 2)
