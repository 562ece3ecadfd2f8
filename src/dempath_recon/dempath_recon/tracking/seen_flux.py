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

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
RIM_PX = 1.0  # the flux disc's radius beyond the marker's [detector px]: the blur's rim (1 and
# 1.5 gave 0.95 and 0.96 px at 70-90 % visible on the nine looks)
RING_PX = (2.0, 4.0)  # the sand's ring around the spot, from and to [detector px beyond the
# marker's radius]: clear of the rim, near enough to share the spot's light
MIN_RING = 6  # ring pixels needed for the sand's level (fewer: the window's edge; NaN flux)


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
    reach = int(np.ceil(radius + RING_PX[1]))
    dy, dx = np.mgrid[-reach:reach + 1, -reach:reach + 1]
    ok = np.isfinite(uv).all(axis=1)
    if not ok.any():
        return out
    base = np.rint(uv[ok]).astype(np.intp)  # (m, 2) the nearest pixel
    cols = base[:, 0, None] + dx.ravel()[None, :]
    rows = base[:, 1, None] + dy.ravel()[None, :]
    h, w = c.shape
    inside = (cols >= 0) & (cols < w) & (rows >= 0) & (rows < h)
    values = c[np.clip(rows, 0, h - 1), np.clip(cols, 0, w - 1)].astype(np.float64)
    dist = np.hypot(cols - uv[ok, 0, None], rows - uv[ok, 1, None])
    ring = inside & (dist >= radius + RING_PX[0]) & (dist < radius + RING_PX[1])
    disc = dist < radius + RIM_PX
    sand = np.where(ring, values, np.nan)
    enough = ring.sum(axis=1) >= MIN_RING
    level = np.zeros(len(base))
    if enough.any():
        level[enough] = np.nanmedian(sand[enough], axis=1)
    flux = np.where(disc & inside, values - level[:, None], 0.0).sum(axis=1)
    whole = enough & ~(disc & ~inside).any(axis=1)  # the disc within the window
    out[np.flatnonzero(ok)] = np.where(whole, flux, np.nan)
    return out
