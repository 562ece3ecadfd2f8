"""A streaked marker beside a track's prediction: a matched filter swept along its motion.

With a long shutter a fast marker smears along its image motion during the exposure: a disc
of diameter ``d`` moving ``L`` px spreads its colour over ``d + L`` px, and where ``L > d`` no
pixel sees the clay for more than ``d / L`` of the exposure. The chroma along the streak's
middle is then a mix of clay and sand (a 9 px marker smeared 16 px at light x0.3: 0.07 against
0.6 still; 20 px: 0.01 on sand of -0.17), under the detector's fixed threshold (0.15) whatever
the light, and the isotropic matched filter, which averages over about one disc, keeps the
peak there. The streak's colour is still there, spread along a known line: the track's
velocity times the exposure. Averaging the chroma along that line (a Gaussian swept along the
segment, the matched filter of the streak; Kay, *Fundamentals of Statistical Signal
Processing, vol. 2: Detection Theory*, 1998, ch. 4: the matched filter maximises the
signal-to-noise ratio of a known shape in white noise) divides the sand's pixel noise by the
square root of the pixels averaged, so a streak whose contrast to the sand is a few hundredths
stands out.

Used only where a numbered track predicts its marker and found nothing (the linker's faint
search, :meth:`~dempath_recon.tracking.detect.MarkerDetector`'s ``faint``), never over the whole
frame: a lower bar over the whole frame (the session-15 adaptive threshold) found spots in
sand and raised wrong pairs. The bar is set by the window's own noise: the filtered chroma
must exceed the window's sand (its median) by ``STREAK_NOISE_K`` robust standard deviations of
the filtered window, and by ``STREAK_MIN_CONTRAST`` at least. The centre is the weighted
centroid of the chroma in a capsule around the segment through the peak (the marker at the
middle of the exposure, which is the frame's stamp), iterated as the detector's centroids are.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
STREAK_MIN_PX = 6.0  # a motion during the exposure shorter than this [full-size px] leaves the
# isotropic filter's peak above the threshold (12 px streaks of 9 px markers are still found)
STREAK_MIN_CONTRAST = 0.06  # least filtered chroma above the window's sand [-] (sand noise
# after the filter is 0.005-0.01 on dusk renders; a 20 px streak of a 9 px marker keeps 0.15-0.2)
STREAK_NOISE_K = 6.0  # robust standard deviations of the filtered window the streak must exceed
CENTROID_ITERATIONS = 6


def streak_kernel(step: FloatArray, sigma: float) -> NDArray[np.float32]:
    """The matched filter of a streak: a Gaussian of ``sigma`` px swept along ``step`` (2,) px
    (centred on the kernel's middle pixel), normalised to unit sum, so the filtered value is the
    mean chroma along the streak."""
    length = float(np.hypot(*step))
    half = int(np.ceil(0.5 * length + 3 * sigma))
    yy, xx = np.mgrid[-half:half + 1, -half:half + 1].astype(np.float64)
    kernel = np.zeros_like(xx)
    for t in np.linspace(-0.5, 0.5, max(2, int(np.ceil(2 * length)) + 1)):
        kernel += np.exp(-((xx - t * step[0]) ** 2 + (yy - t * step[1]) ** 2) / (2 * sigma ** 2))
    return np.asarray(kernel / kernel.sum(), np.float32)


def _segment_distance(xx: FloatArray, yy: FloatArray, centre: FloatArray,
                      step: FloatArray) -> FloatArray:
    """Distance [px] of each pixel (xx, yy) from the segment ``centre +- step / 2``."""
    length2 = float(step @ step)
    dx, dy = xx - centre[0], yy - centre[1]
    t = np.clip((dx * step[0] + dy * step[1]) / length2, -0.5, 0.5) if length2 > 0 else 0.0
    return np.asarray(np.hypot(dx - t * step[0], dy - t * step[1]), np.float64)


def find_streak(c: NDArray[np.float32], centre: FloatArray, step: FloatArray, sigma: float,
                reach: float, radius: float) -> FloatArray:
    """(2,) centre [window px] of a streak near ``centre`` in the chroma window ``c``, NaN if none.

    Args:
        c: (h, w) chroma of a window around the prediction [-] (mostly sand).
        centre: (2,) predicted position [window px].
        step: (2,) the marker's motion during the exposure [px] (velocity x exposure).
        sigma: Gaussian of the detector's matched filter [px].
        reach: farthest the streak's middle may lie from ``centre`` [px].
        radius: a marker's image radius [px] (the capsule the centroid weighs).
    """
    resp = np.asarray(cv2.filter2D(c, -1, streak_kernel(step, sigma),
                                   borderType=cv2.BORDER_REPLICATE), np.float32)
    sand = float(np.median(c))
    spread = float(np.median(np.abs(resp - np.median(resp)))) * 1.4826
    bar = sand + max(STREAK_MIN_CONTRAST, STREAK_NOISE_K * spread)
    h, w = c.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    near = np.hypot(xx - centre[0], yy - centre[1]) <= reach
    if not near.any():
        return np.full(2, np.nan)
    best = np.where(near, resp, -np.inf)
    iy, ix = np.unravel_index(int(np.argmax(best)), best.shape)
    peak = float(resp[iy, ix])
    if peak <= bar:
        return np.full(2, np.nan)
    base = sand + 0.5 * (peak - sand)  # the streak's core: above half its contrast
    cx = np.array([ix, iy], np.float64)
    for _ in range(CENTROID_ITERATIONS):
        inside = _segment_distance(xx, yy, cx, step) <= radius
        wgt = np.where(inside, np.maximum(c - base, 0.0), 0.0)
        total = float(wgt.sum())
        if total <= 0:
            return np.full(2, np.nan)
        new = np.array([(wgt * xx).sum() / total, (wgt * yy).sum() / total])
        moved = float(np.abs(new - cx).sum())
        cx = new
        if moved < 0.01:
            break
    return cx
