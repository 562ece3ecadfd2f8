"""The angles of a pile of spheres on a base, read as the paper's repose device reads them.

The angle is read from the pile's surface profile h(r) (highest particle top per radial ring,
averaged over angular sectors; the same reading on side silhouettes gives ``view_deg``): the
angle from the base is the slope of a line fitted where
h is 10-60 % of the peak, the angle from the top where h is 40-90 % (a stand-in for ESSS's
script, which the paper does not describe). ``cone_deg`` is the line from the apex to the
foot (where h falls to 10 % of the peak) and ``band_deg`` the local slope in five height bands,
so the effect of the measuring window can be shown. The piles come from
:mod:`dempath_sim.validation.repose` (either engine) or are synthetic (the tests' cones).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class ReposeResult:
    """Angles of one pile.

    Attributes:
        engine: 'dempath', 'liggghts' or 'synthetic'.
        base_deg: Angle from the base (flank fit at 10-60 % of the height) [deg].
        top_deg: Angle from the top (flank fit at 40-90 % of the height) [deg].
        cone_deg: Angle of the line from the apex to the foot (10 % of the height) [deg].
        band_deg: (5,) local slope in the height bands 0-20, ..., 80-100 % [deg] (NaN if empty).
        height: Pile height [m].
        r: (k,) profile ring centres [m].
        h: (k,) profile heights [m].
        pos: (n, 3) final sphere centres [m].
        radii: (n,) radii [m].
        sim_time: Simulated time [s] (NaN if not simulated).
        view_deg: (from the base, from the top) read the same way from side silhouettes
            (upper outline of the pile seen from 4 azimuths, both halves) [deg].
    """

    engine: str
    base_deg: float
    top_deg: float
    cone_deg: float
    band_deg: F64
    height: float
    r: F64
    h: F64
    pos: F64
    radii: F64
    sim_time: float = math.nan
    view_deg: tuple[float, float] = (math.nan, math.nan)


def pile_profile(pos: F64, radii: F64, ring: float, sectors: int = 8) -> tuple[F64, F64]:
    """Surface profile: ring centres (k,) [m] and mean over sectors of the highest top [m].

    Ring k is split into min(sectors, max(1, int(pi (k + 0.5)))) sectors, so that no cell is a
    sliver narrower than about two ring widths (a sliver's highest sphere lies below the
    surface and the apex would read low).
    """
    rr = np.hypot(pos[:, 0], pos[:, 2])
    k = (rr / ring).astype(int)
    n_ring = int(k.max()) + 1
    per_ring = np.clip((math.pi * (np.arange(n_ring) + 0.5)).astype(int), 1, sectors)
    frac = (np.arctan2(pos[:, 2], pos[:, 0]) + math.pi) / (2 * math.pi)
    sec = np.minimum((frac * per_ring[k]).astype(int), per_ring[k] - 1)
    tops = np.zeros((sectors, n_ring))
    np.maximum.at(tops, (sec, k), pos[:, 1] + radii)
    used = np.arange(sectors)[:, None] < per_ring[None, :]
    centres = np.asarray((np.arange(n_ring) + 0.5) * ring, dtype=np.float64)
    return centres, np.asarray(tops.sum(axis=0) / used.sum(axis=0), dtype=np.float64)


def side_view(pos: F64, radii: F64, azimuth: float, width: float) -> tuple[F64, F64]:
    """Silhouette of the pile seen from the side, as a camera records it.

    Returns:
        Distance from the axis |u| (k,) [m] and the outline height (k,) [m] for both halves,
        u = x cos(azimuth) + z sin(azimuth), binned at ``width``.
    """
    u = pos[:, 0] * math.cos(azimuth) + pos[:, 2] * math.sin(azimuth)
    k = np.floor(u / width).astype(int)
    k -= k.min()
    tops = np.zeros(int(k.max()) + 1)
    np.maximum.at(tops, k, pos[:, 1] + radii)
    centres = (np.arange(len(tops)) + 0.5) * width + math.floor(u.min() / width) * width
    return np.abs(centres), tops


def _fit_deg(r: F64, h: F64, sel: NDArray[np.bool_]) -> float:
    """Slope angle [deg] of a least-squares line through the selected profile points."""
    x, y = r[sel], h[sel]
    if np.unique(x).size < 2:
        return math.nan
    slope = float(np.sum((x - x.mean()) * (y - y.mean())) / np.sum((x - x.mean()) ** 2))
    return math.degrees(math.atan(-slope))


def flank_angles(r: F64, h: F64, peak: float, r_apex: float = 0.0) -> tuple[float, ...]:
    """Angles of a profile h(r) falling from ``peak`` at ``r_apex`` [m].

    Returns:
        (from the base, from the top, cone, band 0-20 %, ..., band 80-100 %) [deg]; see the
        module docstring.
    """
    after = r >= r_apex

    def window(lo: float, hi: float) -> NDArray[np.bool_]:
        return np.asarray(after & (h >= lo * peak) & (h <= hi * peak))

    bands = [_fit_deg(r, h, window(lo, lo + 0.2)) for lo in (0.0, 0.2, 0.4, 0.6, 0.8)]
    low = after & (h < 0.1 * peak)
    cone = math.nan
    if low.any():
        r_foot = float(r[low].min())  # first point below 10 % of the peak
        cone = math.degrees(math.atan(0.9 * peak / max(r_foot - r_apex, 1e-9)))
    return (_fit_deg(r, h, window(0.1, 0.6)), _fit_deg(r, h, window(0.4, 0.9)), cone, *bands)


def repose_angles(engine: str, pos: F64, radii: F64, sim_time: float = math.nan,
                  views: int = 4) -> ReposeResult:
    """Angles of the pile from its radial profile and from ``views`` side silhouettes."""
    on_base = pos[:, 1] < 0.5  # the whole pile; nothing is left in the lifted tube
    pos, radii = pos[on_base], radii[on_base]
    d = float(2 * radii.mean())
    r, h = pile_profile(pos, radii, d)
    apex = int(np.argmax(h[:3]))
    prof = flank_angles(r, h, float(h[apex]), float(r[apex]))
    sides = []
    for azimuth in np.arange(views) * math.pi / views:
        u, top = side_view(pos, radii, float(azimuth), d)
        sides.append(flank_angles(u, top, float(top.max()))[:2])
    view = np.nanmean(np.array(sides), axis=0)
    return ReposeResult(engine, prof[0], prof[1], prof[2], np.array(prof[3:]), float(h[apex]),
                        r, h, pos, radii, sim_time, (float(view[0]), float(view[1])))


def summarise(results: list[ReposeResult]) -> dict[str, dict[str, tuple[float, float]]]:
    """Mean and sample standard deviation (0 for one run) of each angle per engine [deg]."""
    out: dict[str, dict[str, tuple[float, float]]] = {}
    for eng in dict.fromkeys(r.engine for r in results):
        rows = [r for r in results if r.engine == eng]
        out[eng] = {}
        for key in ('base_deg', 'top_deg', 'cone_deg'):
            vals = np.array([getattr(r, key) for r in rows])
            sd = float(vals.std(ddof=1)) if len(vals) > 1 else 0.0
            out[eng][key] = (float(vals.mean()), sd)
    return out
