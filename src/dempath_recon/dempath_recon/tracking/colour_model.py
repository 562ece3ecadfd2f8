"""The detector's colour model: which colour is a marker, and how dark a pixel may be.

The detector looks for a marker where a pixel's chroma ``(w . [B, G, R]) / max(B + G + R,
floor)`` is high. Two things set that chroma:

- **the colour axis** ``w`` (B, G, R weights): for blue modelling clay (the documented default)
  ``(1, 0, -1)``, i.e. ``(B - R) / (B + G + R)``, about +0.5 on the clay and -0.2 on yellow-brown
  sand. For clay of another colour (red, orange, green) that chroma is near the sand's and no
  marker passes (session 16: red clay gave 0 markers in a whole look). :func:`colour_axis` builds
  the axis from the clay's and the sand's albedo (B, G, R, 0..1) so that, as for blue clay, the
  clay's chromaticity maps to ``CLAY_CHROMA`` and the sand's to ``SAND_CHROMA``: the detector's
  threshold, its sand floor (``FILTER_FLOOR``) and its faint bars keep their meaning for any
  clay. On the chromaticity plane (``x = p / sum(p)``, which light level, gain and shadow leave
  unchanged) the axis is the line from the sand to the clay: ``w = a + d`` with ``d = (CLAY_CHROMA
  - SAND_CHROMA) (x_c - x_s) / |x_c - x_s|^2`` and ``a = CLAY_CHROMA - d . x_c``. A clay close to
  the sand's colour gives a long ``d``, so the chroma's noise grows as the contrast shrinks;
  ``MIN_CONTRAST`` refuses a clay too close to the sand to be told apart.
- **the floor** of the denominator: dark pixels (deep shadow, vignetted corners) would give a
  ratio of sensor noise, so the denominator is floored. A fixed floor of ``MIN_SUM_DN`` (60) was
  set on frames in normal light, whose sand sums to 100-200. At dusk (light x0.28-0.3) the whole
  frame's sand sums to 35-50 and markers in shadow to 25-45 (the twin's dusk renders, session
  17): the fixed floor divided their chroma by up to 2.4, under the threshold. :func:`chroma_floor`
  scales the floor with the frame's exposure, as the frame's median ``B + G + R`` (the sand, most
  of the view) times ``FLOOR_SHARE``, between ``DARK_SUM_DN`` and ``MIN_SUM_DN``: frames in
  normal light keep today's floor, dark frames a floor that keeps the same ratio to the sand.

- **the bed floor** (session 19, ``exposure_floor='bed'``): the frame's median measures the
  ground beyond the bin as well as the bed (on the twin's tiny scene at dusk 25-35 % under the
  bed beside the markers). :func:`bed_floor` floors each pixel at ``BED_SHARE`` of the bed's
  brightness around it (cells of ``BED_CELL`` pixels, the brightest nearby), so a marker is
  judged against its own bed, in light or in shade; :func:`ring_sand_chroma` reads the sand's
  chroma beside the markers found, from which the detector sets that search's threshold.

All are plain arrays; :mod:`~dempath_recon.tracking.detect` applies them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import cv2
import numpy as np
from numpy.typing import NDArray

BLUE_CLAY_BGR = (0.62, 0.22, 0.10)  # blue modelling clay albedo (the twin's default clay)
REFERENCE_SAND_BGR = (0.42, 0.58, 0.72)  # dry quartz sand, yellow-brown (the twin's default)
BLUE_AXIS = (1.0, 0.0, -1.0)  # (B - R): blue clay's axis, the detector's default
CLAY_CHROMA = 0.5  # a clay's chroma on its own axis (blue clay on (B - R) / sum: about +0.5)
SAND_CHROMA = -0.2  # the sand's chroma on the clay's axis (yellow-brown sand on (B - R) / sum)
MIN_CONTRAST = 0.05  # least chromaticity distance between clay and sand (blue clay on the
# reference sand: 0.53; red clay (0.15, 0.18, 0.62) on it: 0.29): closer, the chroma's noise
# would be more than 10 times blue clay's
MIN_SUM_DN = 60.0  # the chroma's floor in frames in normal light (mean 20 grey levels)
DARK_SUM_DN = 12.0  # the lowest floor, in the darkest frames (mean 4 grey levels)
FLOOR_SHARE = 0.6  # the floor as a share of the frame's median B + G + R: sand summing 100
# or more (normal light; every tuning look in daylight: 105-200) keeps MIN_SUM_DN; dusk sand at
# 39 (light x0.28) gets 23, under its markers in shadow (25-45). On six dusk tuning looks
# (session 17) 0.6 found 16-48 more marker-frames than the fixed floor, 0.8 0-2 fewer than 0.6
# and 1.0 2-11 fewer still; the spots 0.6 adds off every marker (2-13 per look) lie in
# near-black pixels and ``lit_peaks`` drops them
LIT_SHARE = 0.5  # under a lowered floor a spot's 5 x 5 pixels must sum to this share of the
# floor (0.3 of the frame's median at FLOOR_SHARE 0.6): the spots off every marker on the dusk
# tuning looks lay at 0.11-0.21 of the median, blue clay (albedo sum 0.94 against the sand's
# 1.72) at 0.55 or more
SAMPLE_STEP = 16  # every 16th pixel of every 16th row (about 2000 at half size) measures the
# frame's median brightness and its sand's colour


def parse_bgr(text: str) -> tuple[float, float, float] | None:
    """A clay albedo from ``'B,G,R'`` text (0..1 each, a node parameter or a CLI option);
    ``''`` or ``'blue'``: None, blue clay (the default).

    Raises:
        ValueError: not three numbers, or a colour :func:`colour_axis` refuses.
    """
    text = text.strip()
    if text in ('', 'blue'):
        return None
    try:
        b, g, r = (float(v) for v in text.split(','))
    except ValueError as err:
        msg = f'marker_bgr: {text!r} is not three numbers B,G,R (albedo 0..1 each) ({err})'
        raise ValueError(msg) from err
    colour_axis((b, g, r))
    return b, g, r


def colour_axis(marker_bgr: Sequence[float] | None,
                sand_bgr: Sequence[float] = REFERENCE_SAND_BGR) -> NDArray[np.float32]:
    """(3,) B, G, R weights of the chroma that is ``CLAY_CHROMA`` on clay of albedo
    ``marker_bgr`` and ``SAND_CHROMA`` on sand of albedo ``sand_bgr`` (B, G, R, 0..1 each).

    None: blue clay's ``BLUE_AXIS``, exactly (the detector's default, tuned on it).

    Raises:
        ValueError: an albedo out of (0, 1], or clay within ``MIN_CONTRAST`` of the sand.
    """
    if marker_bgr is None:
        return np.array(BLUE_AXIS, np.float32)
    clay, sand = (np.asarray(c, np.float64).reshape(-1) for c in (marker_bgr, sand_bgr))
    for name, c in (('marker_bgr', clay), ('sand_bgr', sand)):
        if c.shape != (3,) or not (np.isfinite(c).all() and (c > 0).all() and (c <= 1).all()):
            msg = f'{name}: three B,G,R albedos in (0, 1] wanted, got {tuple(c)!r}'
            raise ValueError(msg)
    xc, xs = clay / clay.sum(), sand / sand.sum()
    gap = xc - xs
    if float(np.hypot.reduce(gap)) < MIN_CONTRAST:
        msg = (f'marker_bgr: clay {tuple(clay)!r} is within {MIN_CONTRAST} of the sand '
               f'{tuple(sand)!r} in chromaticity: markers cannot be told from sand by colour')
        raise ValueError(msg)
    d = (CLAY_CHROMA - SAND_CHROMA) * gap / float(gap @ gap)
    return np.asarray(CLAY_CHROMA - d @ xc + d, np.float32)


def frame_axis(image: NDArray[np.uint8], marker_bgr: Sequence[float] | None,
               sand_bgr: Sequence[float] | None = None) -> NDArray[np.float32]:
    """(3,) the colour axis of ``marker_bgr`` clay in ``image`` (h, w, 3) BGR: from
    ``sand_bgr`` when given, else from the frame's sand as the camera sees it (the median
    chromaticity of every ``SAMPLE_STEP``-th pixel; the sand fills most of the view), so a tint
    of the light or the camera's white balance moves the axis with the sand. Blue clay (None):
    ``BLUE_AXIS``. A frame whose median is within ``MIN_CONTRAST`` of the clay (the view
    filled by something else) falls back to ``REFERENCE_SAND_BGR``."""
    if marker_bgr is None or sand_bgr is not None:
        return colour_axis(marker_bgr, REFERENCE_SAND_BGR if sand_bgr is None else sand_bgr)
    sample = image[::SAMPLE_STEP, ::SAMPLE_STEP].reshape(-1, 3).astype(np.float32)
    total = sample.sum(axis=1, keepdims=True)
    lit = total[:, 0] >= DARK_SUM_DN
    if lit.sum() < 16:
        return colour_axis(marker_bgr, REFERENCE_SAND_BGR)
    sand = np.median(sample[lit] / total[lit], axis=0)
    try:
        return colour_axis(marker_bgr, tuple(np.clip(sand, 1e-3, 1.0)))
    except ValueError:
        return colour_axis(marker_bgr, REFERENCE_SAND_BGR)


def is_blue(axis: NDArray[np.float32]) -> bool:
    """Whether ``axis`` (3,) is blue clay's ``(B - R)`` (the detector's fast paths)."""
    return bool(np.array_equal(axis, np.array(BLUE_AXIS, np.float32)))


def chroma_floor(image: NDArray[np.uint8], share: float = FLOOR_SHARE) -> float:
    """The chroma's floor for ``image`` (h, w, 3) BGR: ``share`` times its median ``B + G + R``
    (every ``SAMPLE_STEP``-th pixel), between ``DARK_SUM_DN`` and ``MIN_SUM_DN`` [DN]."""
    sample = np.ascontiguousarray(image[::SAMPLE_STEP, ::SAMPLE_STEP])
    if sample.size == 0:
        return MIN_SUM_DN
    # saturates at 255: the floor's bound MIN_SUM_DN / FLOOR_SHARE = 100 lies below
    total = np.asarray(cv2.transform(sample, np.ones((1, 3), np.float32)), np.float64)
    return float(np.clip(share * float(np.median(total)), DARK_SUM_DN, MIN_SUM_DN))


def lit_peaks(image: NDArray[np.uint8], rows: NDArray[np.intp], cols: NDArray[np.intp],
              floor: float | BedFloor) -> NDArray[np.bool_]:
    """(n,) whether each peak (``rows``, ``cols`` (n,) in ``image``) lies where the mean
    ``B + G + R`` of its 5 x 5 pixels reaches ``LIT_SHARE`` of the frame's ``floor`` [DN];
    all True where the floor is ``MIN_SUM_DN`` (normal light: as before).

    Why: under a lowered floor, near-black pixels (the tool's shadow, gaps between clods:
    0.11-0.21 of the frame's median brightness on the twin's dusk looks) give ratios of sensor
    noise that pass the threshold, while the markers the lowered floor finds lie at 1.0-1.8
    times the median (session 17: 2-13 such spots per dusk tuning look at a floor of 0.6 x the
    median, none of them near a marker); blue clay darker than its sand, 0.55 of it.
    """
    keep = np.ones(len(rows), np.bool_)
    if not isinstance(floor, BedFloor) and floor >= MIN_SUM_DN:
        return keep
    for k, (y, x) in enumerate(zip(rows, cols, strict=True)):
        at = float(floor.at(int(y), int(y) + 1, int(x), int(x) + 1)[0, 0]) \
            if isinstance(floor, BedFloor) else floor
        patch = image[max(int(y) - 2, 0):int(y) + 3, max(int(x) - 2, 0):int(x) + 3]
        keep[k] = float(patch.astype(np.float32).sum(axis=2).mean()) >= LIT_SHARE * at
    return keep


def near_lit(image: NDArray[np.uint8], floor: float) -> NDArray[np.uint8]:
    """(h, w) uint8: 255 within 2 px of a pixel whose ``B + G + R`` reaches ``LIT_SHARE`` of
    ``floor`` [DN] (at most 255), else 0: every peak :func:`lit_peaks` keeps lies there (a
    5 x 5 mean at that level needs one pixel at it), so the detector's search window may
    leave the rest out: a dusk frame's near-black corners, whose noise passes a lowered
    floor's bound, made it search the whole frame (r21_dusk: 4.5 ms a frame, 2.4 with this;
    0.8 with the fixed floor; noise in dim sand still spreads it on some looks)."""
    total = cv2.add(cv2.add(cv2.extractChannel(image, 0), cv2.extractChannel(image, 1)),
                    cv2.extractChannel(image, 2))
    level = float(np.ceil(LIT_SHARE * floor)) - 1  # B + G + R above it: at the share at least
    lit = cv2.threshold(total, level, 255, cv2.THRESH_BINARY)[1]
    return np.asarray(cv2.dilate(lit, np.ones((5, 5), np.uint8)), np.uint8)


def axis_chroma(image: NDArray[np.uint8], axis: NDArray[np.float32],
                min_sum: float | NDArray[np.float32]) -> NDArray[np.float32]:
    """(h, w) float32 ``(axis . [B, G, R]) / max(B + G + R, min_sum)`` of a BGR image
    (``min_sum`` [DN] one floor, or one per pixel (h, w))."""
    pixels = image.astype(np.float32)
    num = cv2.transform(pixels, axis.reshape(1, 3))
    total = cv2.transform(pixels, np.ones((1, 3), np.float32))
    np.maximum(total, np.float32(min_sum), out=total)
    return np.asarray(cv2.divide(num, total), np.float32)


def axis_bound(image: NDArray[np.uint8], axis: NDArray[np.float32],
               level: float) -> NDArray[np.uint8]:
    """(h, w) uint8: 255 where ``axis . [B, G, R]`` exceeds ``level`` [DN] (every pixel whose
    chroma can exceed ``level / floor``), else 0."""
    num = cv2.transform(image.astype(np.float32), axis.reshape(1, 3))
    return np.asarray((num > level).view(np.uint8) * np.uint8(255), np.uint8)


BED_CELL = 8  # the bed's brightness is measured on cells of 8 x 8 detector pixels (16 x 16
# full size, two marker diameters in the twin's views): coarser than a marker, finer than the
# light's gradients and the bin's edge
BED_REACH = 1  # a cell's bed is the brightest of the cells within this many cells of it: the
# sand beside a marker, not the marker, a gap between clods or the tool's shadow in its cell
BED_MIN_DN = 20.0  # the bed floor's least value: a vignetted corner's bed (B + G + R 5-8 at
# dusk) would floor at DARK_SUM_DN (12), where read noise passes ``lit_peaks`` (s79_dusk_grey:
# spots in all four corners); a marker at dusk sums 25-45
BED_SHARE = 0.5  # the floor as a share of the bed's B + G + R beside a marker: blue clay
# (albedo sum 0.94) on the reference sand (1.72) sums 0.55 of its bed, so its chroma is not
# divided down; darker pixels (gaps, shadows) are floored


class BedFloor(NamedTuple):
    """The chroma's floor from the bed around each pixel (:func:`bed_floor`): ``cells`` (ch, cw)
    float32 [DN], one per ``BED_CELL`` x ``BED_CELL`` cell of the image."""

    cells: NDArray[np.float32]

    def at(self, y0: int, y1: int, x0: int, x1: int) -> NDArray[np.float32]:
        """(y1 - y0, x1 - x0) float32 the floor of each pixel of that part of the image [DN]."""
        ch, cw = self.cells.shape
        rows = np.minimum(np.arange(y0, y1) // BED_CELL, ch - 1)
        cols = np.minimum(np.arange(x0, x1) // BED_CELL, cw - 1)
        return np.ascontiguousarray(self.cells[np.ix_(rows, cols)])

    def level(self, shape: tuple[int, int], scale: float, lowered_only: bool = False,
              ) -> NDArray[np.uint8]:
        """(h, w) uint8 ``scale`` times each pixel's floor, rounded [DN] (a bound on ``B + G +
        R`` or on the axis' weighted sum); with ``lowered_only`` 255 in the cells whose floor
        is ``MIN_SUM_DN`` (nothing passes there)."""
        small = np.clip(np.rint(scale * self.cells), 0, 255).astype(np.uint8)
        if lowered_only:
            small[self.cells >= MIN_SUM_DN] = 255
        big = cv2.resize(small, (small.shape[1] * BED_CELL, small.shape[0] * BED_CELL),
                         interpolation=cv2.INTER_NEAREST)
        h, w = shape
        big = big[:h, :w]
        if big.shape != (h, w):
            big = cv2.copyMakeBorder(big, 0, h - big.shape[0], 0, w - big.shape[1],
                                     cv2.BORDER_REPLICATE)
        return np.asarray(big, np.uint8)


def bed_floor(image: NDArray[np.uint8], share: float | None = None) -> BedFloor | None:
    """The chroma's floor at each pixel of ``image`` (h, w, 3) BGR: ``share`` (None:
    ``BED_SHARE``) times the brightness of the bed around it (the mean ``B + G + R`` of
    ``BED_CELL`` cells, the brightest within ``BED_REACH`` cells), between ``BED_MIN_DN`` and
    ``MIN_SUM_DN`` [DN]; None where that is ``MIN_SUM_DN`` everywhere (the light is normal).

    Why: a marker's chroma is divided by the floor where its ``B + G + R`` is under it. The
    frame's median (:func:`chroma_floor`) measures the sand and the ground beyond the bin
    alike: on the twin's tiny scene at dusk that is 25-35 % under the bed beside the markers
    (r21_dusk: median 39, bed 58, missed markers 31-40). The bed's own level says what a
    marker there sums to (``BED_SHARE`` of it) and floors the darker pixels (gaps, shadows)
    whose ratio is noise; one floor for a frame with light and shade would be wrong in one.
    """
    h, w = image.shape[:2]
    ch, cw = max(h // BED_CELL, 1), max(w // BED_CELL, 1)
    half = BED_CELL // 4  # every 4th pixel of every 4th row: the cell's mean within noise
    cells = cv2.resize(np.ascontiguousarray(image[half:ch * BED_CELL:4, half:cw * BED_CELL:4]),
                       (cw, ch), interpolation=cv2.INTER_AREA)
    total = np.asarray(cv2.transform(cells.astype(np.float32), np.ones((1, 3), np.float32)),
                       np.float32)
    size = 2 * BED_REACH + 1
    bed = cv2.dilate(total, np.ones((size, size), np.uint8))
    share = BED_SHARE if share is None else share
    floor = np.clip(share * bed, BED_MIN_DN, MIN_SUM_DN).astype(np.float32)
    if float(floor.min()) >= MIN_SUM_DN:
        return None
    return BedFloor(floor)


def bed_candidates(image: NDArray[np.uint8], bed: BedFloor, thr: float,
                   axis: NDArray[np.float32]) -> NDArray[np.uint8]:
    """(h, w) uint8: 255 where a marker the bed's floor (and not ``MIN_SUM_DN``) lets pass
    ``thr`` may lie: the axis' weighted sum, averaged over 3 x 3 pixels, above ``thr`` times
    the pixel's floor, in a cell whose floor is lowered, near a lit pixel (``LIT_SHARE`` of
    the floor, as :func:`lit_peaks`). Why the average: at a floor of 20-30 DN the bound is
    3-5 DN, which single pixels of read noise pass all over a dusk frame (the search window
    then spread over the whole frame: 3.5 ms); a peak of the matched filter has neighbours."""
    h, w = image.shape[:2]
    if is_blue(axis):
        num = cv2.subtract(cv2.extractChannel(image, 0), cv2.extractChannel(image, 2))
    else:
        num = np.asarray(cv2.transform(image, axis.reshape(1, 3)), np.uint8)  # saturates at 0
    num = cv2.blur(num, (3, 3))
    above = cv2.compare(num, bed.level((h, w), thr, lowered_only=True), cv2.CMP_GT)
    total = cv2.add(cv2.add(cv2.extractChannel(image, 0), cv2.extractChannel(image, 1)),
                    cv2.extractChannel(image, 2))
    lit = cv2.dilate(cv2.compare(total, bed.level((h, w), LIT_SHARE), cv2.CMP_GE),
                     np.ones((5, 5), np.uint8))
    out = cv2.bitwise_and(above, lit)
    return np.asarray(out, np.uint8)


def ring_sand_chroma(image: NDArray[np.uint8], centres: NDArray[np.float64], radius: float,
                     axis: NDArray[np.float32]) -> float | None:
    """The median chroma on ``axis`` (3,) (floored at ``DARK_SUM_DN``) of the bed around the
    markers found: the pixels of ``image`` (h, w, 3) BGR between 2 and 4 ``radius`` [px] from
    one of ``centres`` (n, 2) [px] and farther than 2 ``radius`` from all. None: no such pixel
    (no marker found). Why there: the frame's median measures the ground beyond the bin as
    well (on the twin's tiny scene most of a dusk frame's dim pixels); the bed beside the
    markers is the sand a marker is told from."""
    h, w = image.shape[:2]
    ok = np.isfinite(centres).all(axis=1) if len(centres) else np.zeros(0, np.bool_)
    pts = np.asarray(centres, np.float64)[ok]
    if not len(pts) or radius <= 0:
        return None
    reach = int(np.ceil(4 * radius)) + 1
    x0, y0 = max(int(pts[:, 0].min()) - reach, 0), max(int(pts[:, 1].min()) - reach, 0)
    x1, y1 = min(int(pts[:, 0].max()) + reach + 1, w), min(int(pts[:, 1].max()) + reach + 1, h)
    if x1 <= x0 or y1 <= y0:
        return None
    outer = np.zeros((y1 - y0, x1 - x0), np.uint8)
    inner = np.zeros_like(outer)
    for cx, cy in pts - (x0, y0):
        centre = (round(cx), round(cy))
        cv2.circle(outer, centre, round(4 * radius), 255, -1)
        cv2.circle(inner, centre, round(2 * radius), 255, -1)
    ring = (outer > 0) & (inner == 0)
    if not ring.any():
        return None
    pixels = np.ascontiguousarray(image[y0:y1, x0:x1]).astype(np.float32)[ring]
    total = np.maximum(pixels.sum(axis=1), DARK_SUM_DN)
    return float(np.median(pixels @ axis / total))
