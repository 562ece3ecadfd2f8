"""Angle-of-repose measurement on synthetic piles of known slope, and the case set-ups."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from dempath_sim.validation.pile import repose_angles, summarise
from dempath_sim.validation.repose import ReposeCase, preset_case


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
    """A lattice cone of slope 20-38 deg reads back within 2 deg (profile and silhouettes)."""
    pos = _cone(angle)
    res = repose_angles('synthetic', pos, np.full(len(pos), 0.002))
    assert res.base_deg == pytest.approx(angle, abs=2.0)
    assert res.top_deg == pytest.approx(angle, abs=2.0)
    assert res.view_deg == pytest.approx((angle, angle), abs=2.0)
    assert res.cone_deg == pytest.approx(angle, abs=2.5)
    assert res.height == pytest.approx(0.05, abs=0.004)


def test_rounded_top_reads_lower_from_the_top() -> None:
    """A 30 deg flank under a 15 deg cap gives ~30 deg from the base and less from the top."""
    a, h0 = 0.002, 0.06
    g = np.arange(-0.12, 0.12 + a, a)
    pts = np.stack(np.meshgrid(g, np.arange(a / 2, h0, a), g, indexing='ij'), -1).reshape(-1, 3)
    r = np.hypot(pts[:, 0], pts[:, 2])
    cap, flank = 0.045 - r * math.tan(math.radians(15)), h0 - r * math.tan(math.radians(30))
    pos = pts[pts[:, 1] + a / 2 <= np.minimum(cap, flank) + a]
    res = repose_angles('synthetic', pos, np.full(len(pos), a / 2))
    assert res.base_deg == pytest.approx(30.0, abs=2.0)
    assert res.top_deg < res.base_deg - 3.0


def test_presets_and_summary() -> None:
    """Presets give distinct seeds and sizes; the summary is the mean and sample sd."""
    big, small = preset_case('large', 2), preset_case('quick')
    assert big.seed == 2 and big.diameter > small.diameter
    with pytest.raises(ValueError, match='huge'):
        preset_case('huge')
    pos = _cone(30.0)
    res = [replace(repose_angles('synthetic', pos, np.full(len(pos), 0.002)), base_deg=b)
           for b in (29.0, 31.0, 33.0)]
    mean, sd = summarise(res)['synthetic']['base_deg']
    assert (mean, sd) == pytest.approx((31.0, 2.0))


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


@pytest.mark.parametrize(('argv', 'needle'), [
    (['--cases', 'repose,bogus'], '--cases'),
    (['--repose-seeds', '0'], '--repose-seeds'),
])
def test_validate_rejects_bad_repose_options(argv: list[str], needle: str,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    """``dempath validate`` rejects a bad case list or seed count with one line, status 1."""
    from dempath_sim.validation.cli import validate_main

    assert validate_main(argv) == 1
    err = capsys.readouterr().err
    assert err.startswith('error: ') and needle in err and err.count('\n') == 1
