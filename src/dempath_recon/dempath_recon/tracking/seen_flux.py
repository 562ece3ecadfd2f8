"""How much of each marker a spot shows, from its chroma flux over the local sand.

A partly covered marker's published centre is its visible part's centroid moved down by the
offset of a sunk disc's seen part (:mod:`~dempath_recon.tracking.covered`), and that offset
grows with the share of the disc that is hidden, so the share's noise becomes the centre's.
The detector's centroid mass (chroma above the spot's core level) is a poor measure of the
area seen: it drops the blurred rim, which is a larger part of a small or faint spot, and it
moves with the level the threshold sets.

The flux used here is linear in what is seen: the spot's chroma minus the local sand's (the
median of a ring around it), summed over a disc a little wider than the marker (its radius
plus ``RIM_PX``: the rim the blur spreads). A marker's chroma is the same all over it (shading
cancels in a chroma), so that flux is the seen area times the clay's contrast over the sand,
and relative to the frame's whole markers' flux (``covered.seen_share``'s reference) it is
the seen share. Measured on nine burnt ``tiny_long`` looks (views at 29-31 degrees, 3,162
isolated marker-frames; session 25, rms25): the share's RMS error against the truth's
visible share 0.08, and the published centres' RMS distance from the true centre at 70-90 %
visible 0.99 -> 0.95 px, at 50-70 % 1.40 -> 1.28 px, whole markers 0.63 -> 0.62 px (with the
truth's own share, the model's floor: 0.81 and 1.22 px).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
RIM_PX = 1.0  # the flux disc's radius beyond the marker's [detector px]: the blur's rim (1 and
# 1.5 gave 0.95 and 0.96 px at 70-90 % visible on the nine looks)
RING_PX = (2.0, 4.0)  # the sand's ring around the spot, from and to [detector px beyond the
# marker's radius]: clear of the rim, near enough to share the spot's light
MIN_RING = 6  # ring pixels needed for the sand's level (fewer: the window's edge; NaN flux)


@lru_cache(maxsize=8)
def _offsets(reach: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(dx, dy), each (m,): the pixel offsets of the square of half-width ``reach`` [px]."""
    dy, dx = np.mgrid[-reach:reach + 1, -reach:reach + 1]
    return dx.ravel(), dy.ravel()


def spot_flux(c: NDArray[np.float32], uv: FloatArray, radius: float) -> FloatArray:
    """(n,) each spot's chroma over the local sand's, summed over a disc about its centroid.

    Args:
        c: (h, w) the chroma the spots were found on [-].
        uv: (n, 2) the spots' centroids in ``c`` [px of ``c``].
        radius: a marker's radius in ``c`` [px].

    Returns:
        The flux [chroma x px^2]; NaN where the centroid is not finite or the ring around it
        leaves ``c``.
    """
    n = len(uv)
    out = np.full(n, np.nan)
    if n == 0 or c.size == 0 or radius <= 0:
        return out
    ok = np.isfinite(uv).all(axis=1)
    if not ok.any():
        return out
    dx, dy = _offsets(int(np.ceil(radius + RING_PX[1])))
    at = uv[ok]
    base = np.rint(at).astype(np.intp)  # (m, 2) the nearest pixel
    cols = base[:, 0, None] + dx[None, :]
    rows = base[:, 1, None] + dy[None, :]
    h, w = c.shape
    inside = (cols >= 0) & (cols < w) & (rows >= 0) & (rows < h)
    values = c[np.clip(rows, 0, h - 1), np.clip(cols, 0, w - 1)]
    dist2 = (cols - at[:, 0, None]) ** 2 + (rows - at[:, 1, None]) ** 2
    ring = inside & (dist2 >= (radius + RING_PX[0]) ** 2) & (dist2 < (radius + RING_PX[1]) ** 2)
    disc = dist2 < (radius + RIM_PX) ** 2
    count = ring.sum(axis=1)
    enough = count >= MIN_RING
    # each ring's median: its values sorted first (the rest set past them), the middle one
    # or two (a sort of the rows is several times cheaper than ``nanmedian``)
    sand = np.sort(np.where(ring, values, np.float32(np.inf)), axis=1)
    half = np.maximum(count - 1, 0)
    level = 0.5 * (np.take_along_axis(sand, (half // 2)[:, None], axis=1)[:, 0]
                   + np.take_along_axis(sand, ((half + 1) // 2)[:, None], axis=1)[:, 0])
    level = np.where(enough, level, np.float32(0.0))
    flux = np.where(disc, values - level[:, None], np.float32(0.0)).sum(axis=1, dtype=np.float64)
    whole = enough & ~(disc & ~inside).any(axis=1)  # the disc within the window
    out[np.flatnonzero(ok)] = np.where(whole, flux, np.nan)
    return out
