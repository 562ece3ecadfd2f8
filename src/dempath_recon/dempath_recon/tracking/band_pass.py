"""Markers found on the chroma less its local background, kept by a blur-proof seen share.

The detector's fixed rule (a pixel's chroma over ``threshold``, the matched filter's peak there
over half of it) measures a marker against an absolute chroma: 0.15, the midpoint between the
reference sand (-0.2) and blue clay (+0.5). Three things of the field move a marker's chroma
down without moving it towards the sand's: a colour cast (a reddish sand or light: clay and
sand both shift), a JPEG's chroma (stored at half resolution in 16 x 16-pixel blocks and
quantised hard at quality 50-60, which spreads a 6-7 px marker's chroma over its block and
lowers its peak to 0.1-0.3), and a partly covered marker's small visible part. Crocker and
Grier's band-pass (1996, sec. 2) measures a spot against the background around it instead:
the matched filter (a Gaussian of the marker's scale) less the local mean of the chroma over
a square of ``BAND_WIDTH`` diameters.

Measured on the tuning looks (session 24; the bundled render's tuned variations and burnt
heldout24/25 looks, in the box of the markers, sand farther than two diameters from every
marker): at no spot off the markers the band-pass kept 97-98 % of the markers at least half
visible where the fixed rule kept 94 % (JPEG 60 with noise 6: 89 -> 97 %; reddish sand: 93 ->
99 %). A per-frame noise bar (the filtered chroma's robust deviation times a factor) did worse
than either (87 %): the sand's strongest local maxima are its texture, 13-35 deviations
high, not noise.

What the band-pass adds that the fixed rule did not find is of two kinds: whole markers of
low contrast (cast, JPEG) and markers under half visible (coming out of the sand, half buried
in front of the tine), which the linker jumps onto (the dim pass's lesson, session 23). They
are told apart by the spot's excess chroma (over the local background, only what lies above
it) summed over a disc of ``MASS_REACH`` diameters' radius around it: blur, JPEG's block smear
and a cast's lower contrast spread or scale a marker's excess but keep its sum nearly whole,
burial takes it away. Relative to the frame's whole markers (``covered.WHOLE_QUANTILE`` of its
spots) it tracked the truth's visible share within about 0.1 on the tuning looks; a spot the
fixed rule would not have kept is kept only at ``MIN_SHARE`` or more.

The candidates are the fixed rule's pixels (chroma over the threshold), so the detector's
window and cost stay; lower candidate levels (0.10, 0.05) found 1-2 % more markers on JPEG 60
with noise 6 only, at 1.4-2.4 ms more a frame (the candidates' window then spreads over the
sand's noise).

Reference: J. C. Crocker, D. G. Grier, "Methods of digital video microscopy for colloidal
studies", J. Colloid Interface Sci. 179 (1996) 298-310.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.covered import MIN_SPOTS, WHOLE_QUANTILE

FloatArray = NDArray[np.float64]
BAND_WIDTH = 2.5  # the local background is the mean floored chroma over a square of side
# 2 round(BAND_WIDTH d) + 1 around each pixel (d: a marker's diameter) [-]: wide enough that a
# marker hardly raises it (a 3.2 px disc at half size in 17 x 17 pixels: +0.02), narrow enough
# to follow the sand's colour from patch to patch. 1.5, 2.5 and 4 kept the same markers within
# 0.4 % at no spot off the markers (tuning looks)
BAND_THRESHOLD = 0.16  # a band-passed peak (the matched filter less the local background) a
# marker must exceed [-]: the sand's strongest band-passed local maxima in the markers' box,
# over 84 frames of 12 tuning looks, reached 0.15-0.16; blue clay stands 0.5-0.7 above its
# background
MIN_SHARE = 0.5  # a spot the fixed rule would not keep (its filtered peak under half of it)
# is kept when its excess mass says at least this share of a whole marker is seen [-]: the
# issue's markers are those at least half visible. Chosen on the tuning looks: at 0.4 the
# spots of markers 30-47 % visible beside others (the tiny_long looks' bunched markers) passed
# and the linker jumped onto them (burnt Q195_clay 0 -> 3 switches, Q197_asis 84.8 -> 81.1 %
# numbered right); at 0.5 neither, and the variations kept most of 0.4's gain
MASS_REACH = 0.75  # the excess mass is summed over a disc of this many diameters' radius [-]:
# a JPEG block's smear and the matched filter's reach; 1.0 took in a bunched neighbour's
# chroma (markers 12-15 px apart at 8-9 px across)


def band_square(diameter_px: float) -> int:
    """The side of the background square [detector px] for markers ``diameter_px`` across
    [detector px] (odd, at least 3)."""
    return max(2 * round(BAND_WIDTH * diameter_px) + 1, 3)


def local_background(part: NDArray[np.float32], band: int) -> NDArray[np.float32]:
    """(h, w) the mean of ``part`` (h, w), the detector's floored chroma, over ``band`` x
    ``band`` pixels around each pixel (OpenCV's reflected border, as the matched filter's, so
    a window padded by the filters' reach gives the whole frame's values inside)."""
    return np.asarray(cv2.blur(part, (band, band)), np.float32)


@lru_cache(maxsize=16)
def _disc(radius: float) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Row and column offsets (m,) each of the pixels within ``radius`` [px] of a pixel."""
    r = int(np.ceil(radius))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    inside = np.hypot(yy, xx) <= radius
    return np.asarray(yy[inside], np.intp), np.asarray(xx[inside], np.intp)


def excess_mass(part: NDArray[np.float32], rows: NDArray[np.intp], cols: NDArray[np.intp],
                band: int, radius: float) -> FloatArray:
    """(n,) each spot's excess chroma: ``part`` (h, w; the floored chroma) above the local
    background at the spot's pixel (``rows``, ``cols`` (n,); the mean over ``band`` x
    ``band`` pixels), only what lies above it, summed over the pixels within ``radius`` [px]
    (those off ``part`` left out)."""
    if not len(rows):
        return np.zeros(0)
    rows, cols = np.asarray(rows, np.intp), np.asarray(cols, np.intp)
    # the background read at the spots only (the square's pixels gathered; OpenCV's reflected
    # border where the square leaves ``part``): a whole-window box filter cost 0.1-0.3 ms
    half = band // 2
    square = np.arange(-half, half + 1)
    background = _gather(part, rows[:, None, None] + square[None, :, None],
                         cols[:, None, None] + square[None, None, :]).mean(axis=(1, 2))
    dy, dx = _disc(radius)
    h, w = part.shape
    y, x = rows[:, None] + dy[None], cols[:, None] + dx[None]
    inside = (y >= 0) & (y < h) & (x >= 0) & (x < w)
    values = part[np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)] - background[:, None]
    return np.asarray(np.where(inside, np.maximum(values, 0.0), 0.0).sum(axis=1), np.float64)


def _gather(image: NDArray[np.float32], y: NDArray[np.intp], x: NDArray[np.intp],
            ) -> NDArray[np.float64]:
    """``image`` (h, w) at pixels (``y``, ``x``, any shape), those off it reflected as
    OpenCV's default border (``BORDER_REFLECT_101``: -1 reads 1, h reads h - 2)."""
    h, w = image.shape

    def reflect(i: NDArray[np.intp], n: int) -> NDArray[np.intp]:
        if n == 1:
            return np.zeros_like(i)
        period = 2 * (n - 1)
        i = np.abs(i) % period
        return np.where(i >= n, period - i, i)

    return np.asarray(image[reflect(y, h), reflect(x, w)], np.float64)


def kept_spots(strong: NDArray[np.bool_], mass: FloatArray) -> NDArray[np.bool_]:
    """(n,) which spots to keep: those ``strong`` (n,) (the fixed rule's), and the others
    whose excess ``mass`` (n,) is at least ``MIN_SHARE`` of the frame's whole marker's
    (``WHOLE_QUANTILE`` of all its spots' masses); with fewer than ``MIN_SPOTS`` spots there
    is no reference and only the strong ones are kept."""
    strong = np.asarray(strong, np.bool_)
    if strong.all() or len(mass) < MIN_SPOTS:
        return strong
    whole = float(np.percentile(mass, WHOLE_QUANTILE))
    return strong | (mass >= MIN_SHARE * whole) if whole > 0 else strong
