"""Centres of partly covered markers: the sphere's centre, not the middle of its visible cap.

A marker sunk in the heap shows only its upper part: the sand in front hides the part of its
disc that lies below it in the world. The detector's centroid is the middle of what is seen,
which lies up the image from the sphere's centre (isolated markers of 13 tuning re-renders,
mean distance from the true centre, mostly upwards: 1.9 px at 50-60 % visible, 1.6 px at
60-70 %, 1.4 px at 70-80 %, 0.5 px from 90 %, for 8 px markers), and that shift reaches 3D as
a bias of the marker's height.

The model: a sphere sunk in a flat sand surface, seen from the line of sight's elevation
``e`` above it (from the calibration, ``associate.view_of_up``). Side-on the hidden part of its
image disc (radius ``r`` from the calibration and the markers' depth) is a segment below a
chord across the image's up direction; from higher up the boundary bows down and the seen part
lies nearer the centre (from straight above, a smaller disc about it). The seen part's area is
a share ``v`` of the disc and its centroid lies ``g(v, e) r`` up from the disc's centre
(``segment_offset``: 0 for a whole disc; side-on ``4 / (3 pi)`` = 0.42 for a half, 0.41 at 30
degrees, 0.27 at 66). ``v`` comes from the spot's chroma mass: the detector's centroid weight
(the chroma above the core level summed over its window) over the spot's peak contrast,
relative to the same measure of the frame's whole markers (``WHOLE_QUANTILE`` of its spots:
above the median, as some of a frame's markers are covered). Chroma is the same all over a
marker (shading cancels), so that ratio measures the area seen. A spot seen at
``v < MAX_SHARE`` is moved ``g(v, e) r`` down the up direction, in views up to
``MAX_ELEVATION_DEG``.

Only the published points move (``Detections.centre``): linking, numbering and the pair checks
keep the measured centroids. Moving the centroids the trackers use as well was tried on the
same looks and not kept: numbered right 75.6 -> 72.0 % and wrong-pair 3D points 4 -> 12,
as the covered side is not always below (on the side camera the chord is often slanted) and
the mass is noisy, so the numbering's fine margins (a grid point "almost as near") flipped.

Measured on the tuning re-renders (views at 29-31 degrees; isolated markers, 1,556
marker-frames): RMS distance from the true centre 1.09 -> 0.93 px; at 40-80 % visible the mean
fell from 1.4-2.0 px to 1.0-1.4 px; markers at least 90 % visible went 0.48 -> 0.57 px (some
whole markers read as 80 %). Spots larger than one marker (two touching) read as more than
whole and are never moved; the fitted markers of a split blob are the fit's disc centres and
are not moved either.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
WHOLE_QUANTILE = 60.0  # a frame's whole marker's area: this percentile of its spots' (chosen
# among 50, 60 and 75 on the tuning re-renders' isolated markers: RMS 0.93, 0.93, 0.97 px)
MIN_SPOTS = 5  # spots a frame needs for its whole-marker mass to count
MAX_SHARE = 0.9  # spots whose mass says more than this share of the disc is seen stay put
# (0.7 and 0.8 gave 0.98 and 0.95 px)
MAX_ELEVATION_DEG = 50.0  # views steeper than this are left alone: there a half-seen marker's
# centroid lies under 0.3 radii from its centre (0.27 at 66 degrees), less than the mass-based
# share's noise moves it; the bundled render (views at 66 and 75 degrees) lost 3D accuracy with
# the correction (tuned variation as rendered: 1.35 -> 1.52 mm RMS), the re-renders of another
# renderer (views at 29-31 degrees) gained (13 tuning looks: 1.29 -> 1.14 mm). The bound lies
# between the two measured views; views between 31 and 66 degrees were not measured.


@lru_cache(maxsize=16)
def _view_table(elevation_deg: float, n: int = 161) -> tuple[FloatArray, FloatArray]:
    """(shares, offsets) in increasing share: a sphere of radius 1 sunk in a flat sand surface
    to each centre height ``z0`` in -1..1, seen (orthographically) from ``elevation_deg``
    above the surface: the share of its image disc that is seen, and that part's centroid
    along the image's up direction [radii].

    A point of the disc at ``(u, w)`` (w up the image) shows the sphere's front surface, at
    height ``z0 + w cos(e) + sqrt(1 - u^2 - w^2) sin(e)``; it is seen where that is above the
    sand (the sand in front hides the rest). Side-on (0 degrees) the hidden part is a segment
    below a chord; from above (90 degrees) a sunk sphere shows a smaller disc about its centre.
    """
    e = np.radians(elevation_deg)
    x = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    u, w = np.meshgrid(x, x)
    disc = u * u + w * w < 1.0
    w = w[disc]
    height = w * np.cos(e) + np.sqrt(1.0 - u[disc] ** 2 - w * w) * np.sin(e)
    order = np.argsort(-height)  # seen first as the sphere rises
    count = np.arange(1, len(w) + 1)
    shares = count / len(w)
    offsets = np.cumsum(w[order]) / count
    return np.asarray(shares, np.float64), np.asarray(offsets, np.float64)


def segment_offset(share: FloatArray, elevation_deg: float = 0.0) -> FloatArray:
    """How far [disc radii] the centroid of the seen part of a sunk marker's disc lies up the
    image from the disc's centre, for the seen part's share of the disc (0..1) and the view's
    elevation above the sand [degrees] (``_view_table``; side-on: a circular segment's
    centroid, 4 / (3 pi) for a half)."""
    shares, offsets = _view_table(round(float(elevation_deg), 1))
    return np.asarray(np.interp(np.clip(share, 0.0, 1.0), shares, offsets), np.float64)


def seen_share(mass: FloatArray, contrast: FloatArray | None) -> FloatArray | None:
    """(n,) each spot's share of a whole marker's area seen: its chroma mass over its peak
    contrast, relative to the frame's whole markers (``WHOLE_QUANTILE`` of the same over the
    frame's spots); None with fewer than ``MIN_SPOTS`` spots (no reference).

    Args:
        mass: (n,) each spot's chroma above the core level summed over the centroid window.
        contrast: (n,) each spot's peak chroma above the core level; None: the frame's markers
            share one contrast (their clay's chroma, which shading leaves alone), and the mass
            alone, relative to the frame's whole markers', is the share (another clay's
            peak pixel is too noisy to divide by: ``detect.MarkerDetector._spots``).
    """
    area = np.asarray(mass, np.float64) if contrast is None else \
        np.asarray(mass, np.float64) / np.maximum(np.asarray(contrast, np.float64), 1e-6)
    ok = np.isfinite(area) & (area > 0)
    if ok.sum() < MIN_SPOTS:
        return None
    whole = float(np.percentile(area[ok], WHOLE_QUANTILE))
    return np.where(ok, area / whole, 1.0) if whole > 0 else None


def uncover(uv: FloatArray, share: FloatArray, radius_px: float, up: tuple[float, float],
            movable: NDArray[np.bool_], elevation_deg: float = 0.0,
            ) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Spot centres moved from the middle of their visible part to their disc's centre.

    Args:
        uv: (n, 2) spot centroids [px].
        share: (n,) share of each marker's disc seen (``seen_share``).
        radius_px: a marker's radius in the image [px, the units of ``uv``].
        up: the image direction of world up at the markers (a unit vector; the visible part of
            a covered marker lies that way from its centre).
        movable: (n,) spots that are centroids of one marker (not fitted parts of a split blob).
        elevation_deg: the line of sight's elevation above the sand at the markers [degrees];
            above ``MAX_ELEVATION_DEG`` nothing moves.

    Returns:
        ``(uv, moved)``: the centres, and which were moved.
    """
    moved = movable & (share < MAX_SHARE) & np.isfinite(uv).all(axis=1) \
        & (elevation_deg <= MAX_ELEVATION_DEG)
    step = segment_offset(share, elevation_deg) * radius_px
    out = np.asarray(uv, np.float64).copy()
    out[moved] -= step[moved, None] * np.asarray(up, np.float64)[None, :]
    return out, moved
