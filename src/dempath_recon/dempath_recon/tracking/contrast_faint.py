"""A faint marker beside a track's prediction in normal light: found by its contrast to the
window's own sand, kept only where it shows at least half a marker.

The linker's faint search (``Detections.faint``) looks beside a numbered track's prediction
for a spot its detector missed. In normal light it asks for the fixed bars (a pixel over
``faint_threshold``, the matched filter over half of it): an absolute chroma, which JPEG's
chroma (stored at half resolution in 16 x 16-pixel blocks and quantised hard at quality 50-60)
and a half-covered marker's small visible part push under, while the marker still stands
0.12-0.20 above the sand around it (the tuned variation ``noise_jpeg60``: 44 of its 50 missed
marker-frames lay beside a live track, filtered peak about 0, band-passed 0.17; session 26).

**The bar** is the window's own: the matched filter's peak must exceed the window's sand (its
median chroma) by ``streak.STREAK_NOISE_K`` robust standard deviations of the filtered window
(a constant false-alarm rate whatever the noise and JPEG make of the sand), and by
``streak.STREAK_MIN_CONTRAST`` at least: :func:`~dempath_recon.tracking.streak.find_streak`
with no motion, the search the dim windows already use (``DetectorConfig.local_bar``). The
search disc is small (the linker's ``faint_gate_px`` around the prediction), which keeps the
false alarms of any bar few.

**The share.** What such a bar finds beside a prediction is not always the track's marker: a
neighbour's sliver coming out of the sand (6 % visible, 2 px from the prediction on a fast
burnt look) took a track that then followed the neighbour (13 more identity switches on that
look without this test). A spot is kept only where its excess chroma over the local background
(:func:`~dempath_recon.tracking.band_pass.excess_mass`: blur, JPEG's smear and a colour cast
spread or scale a marker's excess but keep its sum; burial takes it away) is at least
``band_pass.MIN_SHARE`` of the frame's whole marker's (``covered.WHOLE_QUANTILE`` of the
frame's own spots' excess): the issue's markers are those at least half visible, and a track
that keeps to its own marker through a half-covered stretch is kept there.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.band_pass import MASS_REACH, band_square, excess_mass
from dempath_recon.tracking.centroid_kernel import refine_centroids
from dempath_recon.tracking.covered import MIN_SPOTS, WHOLE_QUANTILE
from dempath_recon.tracking.streak import CENTROID_ITERATIONS, STREAK_MIN_CONTRAST, STREAK_NOISE_K

FloatArray = NDArray[np.float64]
FAINT_SHARE = 0.25  # least share of a whole marker's excess chroma a contrast spot shows [-]:
# JPEG's quantiser takes part of a small marker's excess away (markers at least half visible
# beside a live track on the tuned variations read 0.25-0.7 of the frame's strongest spots at
# JPEG 60, 0.23-0.49 on reddish sand), where a neighbour's sliver coming out of the sand (6 %
# visible) read 0.27 and a marker under a fifth visible 0.13-0.22 on the burnt looks
ISOLATION = 3.0  # a contrast spot within this many marker diameters of one of the frame's own
# spots is refused [-]: there a track kept alive on its faint marker can be drawn onto the
# neighbour as its own sinks (the burnt fast looks: every contrast spot that fed a switch lay
# 1.5-2.4 diameters from a spot; the tuned variations' faint markers lay 4.4-7.8 apart)


def whole_excess(masses: FloatArray) -> float:
    """A whole marker's excess chroma in a frame: ``WHOLE_QUANTILE`` of its spots' ``masses``
    (n,) [chroma x detector px^2]; NaN with fewer than ``MIN_SPOTS`` spots (no reference)."""
    masses = np.asarray(masses, np.float64)
    masses = masses[np.isfinite(masses)]
    if len(masses) < MIN_SPOTS:
        return float('nan')
    return float(np.percentile(masses, WHOLE_QUANTILE))


def contrast_spot(part: NDArray[np.float32], centre: FloatArray, others: FloatArray,
                  whole: Callable[[], float], *, sigma: float, reach: float, radius: float,
                  diameter: float) -> FloatArray:
    """(2,) the centre [window px] of a marker within ``reach`` [px] of ``centre`` (2,) [window
    px] in the floored chroma window ``part`` (h, w) that stands out of the window's sand by
    its own noise bar, lies farther than ``ISOLATION`` diameters from the frame's other spots
    and shows at least ``FAINT_SHARE`` of a whole marker; NaN where none.

    Args:
        part: (h, w) the detector's chroma floored at the sand (``FILTER_FLOOR``) [-].
        centre: (2,) the track's prediction [window px].
        others: (m, 2) the frame's own spots [window px].
        whole: a whole marker's excess chroma in this frame (:func:`whole_excess`; asked only
            for a spot that passed the bar and the isolation); NaN: no reference, no spot.
        sigma: the matched filter's Gaussian [px].
        reach: farthest the spot's centre may lie from ``centre`` [px].
        radius: the centroid's capsule [px] (the detector's centroid window).
        diameter: a marker's image diameter [px].
    """
    spot = contrast_peak(part, np.asarray(centre, np.float64), sigma, reach, radius)
    if not np.isfinite(spot).all() or np.hypot(*(spot - centre)) > reach:
        return np.full(2, np.nan)  # none, or its centroid drew off the gate: another's spot
    others = np.asarray(others, np.float64).reshape(-1, 2)
    if len(others) and np.hypot(*(others - spot).T).min() <= ISOLATION * diameter:
        return np.full(2, np.nan)
    h, w = part.shape
    row = np.array([min(max(round(float(spot[1])), 0), h - 1)], np.intp)
    col = np.array([min(max(round(float(spot[0])), 0), w - 1)], np.intp)
    mass = float(excess_mass(part, row, col, band_square(diameter), MASS_REACH * diameter)[0])
    reference = whole()
    if not np.isfinite(reference) or reference <= 0:
        return np.full(2, np.nan)
    return spot if mass >= FAINT_SHARE * reference else np.full(2, np.nan)



def contrast_peak(part: NDArray[np.float32], centre: FloatArray, sigma: float, reach: float,
                  radius: float) -> FloatArray:
    """(2,) the centre [window px] of the spot whose matched-filter peak lies within ``reach``
    [px] of ``centre`` (2,) [window px] in the chroma window ``part`` (h, w) and exceeds the
    window's sand (its median) by ``STREAK_NOISE_K`` robust standard deviations of the filtered
    window and ``STREAK_MIN_CONTRAST`` at least (both from every other pixel of every other
    row); NaN where none.

    The bar and the centre are :func:`~dempath_recon.tracking.streak.find_streak`'s with no
    motion (the weighted centroid of the chroma above half the peak's contrast, in a disc of
    ``radius`` [px] about it, iterated: the detector's compiled
    :func:`~dempath_recon.tracking.centroid_kernel.refine_centroids`): that function sweeps a
    kernel it builds per call and weighs the whole window at each step (0.85 ms a call), where
    a marker's disc needs a Gaussian and a few pixels.
    """
    resp = np.asarray(cv2.GaussianBlur(part, (0, 0), sigma, borderType=cv2.BORDER_REPLICATE),
                      np.float32)
    h, w = part.shape
    r = int(np.ceil(reach))
    x0, y0 = max(int(np.floor(centre[0])) - r, 0), max(int(np.floor(centre[1])) - r, 0)
    x1, y1 = min(int(np.ceil(centre[0])) + r + 1, w), min(int(np.ceil(centre[1])) + r + 1, h)
    if x1 <= x0 or y1 <= y0:
        return np.full(2, np.nan)
    dy = np.arange(y0, y1, dtype=np.float64)[:, None] - centre[1]
    dx = np.arange(x0, x1, dtype=np.float64)[None, :] - centre[0]
    near = dx * dx + dy * dy <= reach * reach
    if not near.any():
        return np.full(2, np.nan)
    best = np.where(near, resp[y0:y1, x0:x1], -np.inf)
    iy, ix = np.unravel_index(int(np.argmax(best)), best.shape)
    peak = float(best[iy, ix])
    # the window's sand and noise from every other pixel of every other row (the filtered
    # values are correlated over the Gaussian's sigma: a quarter of them say as much, at a
    # quarter of the medians' cost)
    sand = _middle(part[::2, ::2])
    sample = resp[::2, ::2]
    spread = 1.4826 * _middle(np.abs(sample - _middle(sample)))
    if peak <= sand + max(STREAK_MIN_CONTRAST, STREAK_NOISE_K * spread):
        return np.full(2, np.nan)
    base = sand + 0.5 * (peak - sand)  # the spot's core: above half its contrast
    out, size, mass = np.zeros((1, 2)), np.zeros(1), np.zeros(1)
    refine_centroids(np.ascontiguousarray(part, np.float32), np.array([y0 + iy], np.intp),
                     np.array([x0 + ix], np.intp), float(radius), int(np.ceil(radius)) + 1,
                     base, CENTROID_ITERATIONS, 0.01, out, size, mass)
    return np.asarray(out[0], np.float64)


def _middle(values: NDArray[np.float32]) -> float:
    """The median of ``values`` (any shape; the upper of the two middle values for an even
    count) by one partial sort: ``np.median``'s checks cost five times the sort on a few
    hundred values."""
    flat = np.ravel(values)
    k = len(flat) // 2
    return float(np.partition(flat, k)[k])
