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

Both are plain arrays; :mod:`~dempath_recon.tracking.detect` applies them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

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
CLAY_DARK_SHARE = 0.5  # another clay's spot must be at least this share of the frame's median
# B + G + R bright (5 x 5 mean): on 11 renders of red, orange and green clay (session 20) every
# marker at least half visible lay at 0.69 or more (0.80 but on green clay), the spots off every
# marker (a vignetted view's near-black corners, whose JPEG tint passes another clay's axis)
# at 0.61 at most, 95 % under 0.33; 0.45 and 0.55 gave the same figures
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


def frame_brightness(image: NDArray[np.uint8]) -> float:
    """The median ``B + G + R`` [DN] of ``image`` (h, w, 3) BGR over every ``SAMPLE_STEP``-th
    pixel (the sand, most of the view; saturating at 255); NaN for an empty image."""
    sample = np.ascontiguousarray(image[::SAMPLE_STEP, ::SAMPLE_STEP])
    if sample.size == 0:
        return float('nan')
    total = np.asarray(cv2.transform(sample, np.ones((1, 3), np.float32)), np.float64)
    return float(np.median(total))


def chroma_floor(image: NDArray[np.uint8], share: float = FLOOR_SHARE) -> float:
    """The chroma's floor for ``image`` (h, w, 3) BGR: ``share`` times its median ``B + G + R``
    (:func:`frame_brightness`), between ``DARK_SUM_DN`` and ``MIN_SUM_DN`` [DN]."""
    median = frame_brightness(image)
    if not np.isfinite(median):
        return MIN_SUM_DN
    # the median saturates at 255: the floor's bound MIN_SUM_DN / FLOOR_SHARE = 100 lies below
    return float(np.clip(share * median, DARK_SUM_DN, MIN_SUM_DN))


def lit_peaks(image: NDArray[np.uint8], rows: NDArray[np.intp], cols: NDArray[np.intp],
              floor: float | NDArray[np.float32]) -> NDArray[np.bool_]:
    """(n,) whether each peak (``rows``, ``cols`` (n,) in ``image``) lies where the mean
    ``B + G + R`` of its 5 x 5 pixels reaches ``LIT_SHARE`` of the frame's ``floor`` [DN];
    all True where the floor is ``MIN_SUM_DN`` (normal light: as before).

    Why: under a lowered floor, near-black pixels (the tool's shadow, gaps between clods:
    0.11-0.21 of the frame's median brightness on the twin's dusk looks) give ratios of sensor
    noise that pass the threshold, while the markers the lowered floor finds lie at 1.0-1.8
    times the median (session 17: 2-13 such spots per dusk tuning look at a floor of 0.6 x the
    median, none of them near a marker); blue clay darker than its sand, 0.55 of it.
    """
    if not isinstance(floor, np.ndarray) and floor >= MIN_SUM_DN:
        return np.ones(len(rows), np.bool_)
    at = np.asarray(floor, np.float64) if isinstance(floor, np.ndarray) else float(floor)
    return np.asarray(patch_brightness(image, rows, cols) >= LIT_SHARE * at, np.bool_)


_PATCH_OFFSETS = (np.repeat(np.arange(-2, 3), 5)[None], np.tile(np.arange(-2, 3), 5)[None])
# (1, 25) each: the row and column offsets of a 5 x 5 patch around a pixel


def patch_brightness(image: NDArray[np.uint8], rows: NDArray[np.intp],
                     cols: NDArray[np.intp]) -> NDArray[np.float64]:
    """(n,) the mean ``B + G + R`` [DN] of the 5 x 5 pixels around each peak (``rows``,
    ``cols`` (n,) in ``image``; clipped at the image's edges)."""
    # gathered for every peak at once (one peak at a time cost 5 us each, and the window's
    # bright-pixel box asks it of a few hundred pixels a frame): the 5 x 5 offsets' sums, those
    # off the image left out; integer sums, then the mean in float32 as a patch's own mean is
    h, w = image.shape[:2]
    y = np.asarray(rows, np.intp)[:, None] + _PATCH_OFFSETS[0]
    x = np.asarray(cols, np.intp)[:, None] + _PATCH_OFFSETS[1]
    inside = (y >= 0) & (y < h) & (x >= 0) & (x < w)
    pixels = image[np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)].astype(np.int64).sum(axis=2)
    total = np.where(inside, pixels, 0).sum(axis=1).astype(np.float32)
    count = inside.sum(axis=1).astype(np.float32)
    return np.asarray(total / np.maximum(count, np.float32(1.0)), np.float64)


def bright_peaks(image: NDArray[np.uint8], rows: NDArray[np.intp], cols: NDArray[np.intp],
                 bar: float) -> NDArray[np.bool_]:
    """(n,) whether each peak (``rows``, ``cols`` (n,) in ``image``) lies where the mean
    ``B + G + R`` of its 5 x 5 pixels reaches ``bar`` [DN] (all True for a bar of 0)."""
    if bar <= 0:
        return np.ones(len(rows), np.bool_)
    return np.asarray(patch_brightness(image, rows, cols) >= bar, np.bool_)


def clay_bar(image: NDArray[np.uint8], axis: NDArray[np.float32]) -> float:
    """The least 5 x 5 mean ``B + G + R`` [DN] a spot of ``axis``'s clay may have in
    ``image``: ``CLAY_DARK_SHARE`` of the frame's median brightness on another clay's axis, 0
    on ``BLUE_AXIS`` (blue clay keeps its tuned detection)."""
    if is_blue(axis):
        return 0.0
    median = frame_brightness(image)
    return CLAY_DARK_SHARE * median if np.isfinite(median) else 0.0


class ChromaParts(NamedTuple):
    """A window's chroma before its floor: ``num / max(total, floor)`` for any floor.

    The detector reads one window's chroma at two floors (the frame-wide ``MIN_SUM_DN`` and, in
    a dim frame, the frame's own light: :mod:`~dempath_recon.tracking.shaded`); the numerator
    and ``B + G + R`` do not depend on the floor, so they are computed once (on red clay at
    dusk the window is the whole frame and the second chroma cost 1-2 ms a frame, session 22).

    Attributes:
        num: (h, w) ``B - R`` (int16, blue clay) or ``axis . [B, G, R]`` (float32).
        total: (h, w) ``B + G + R`` (int16, blue clay; float32 for another clay) [DN].
    """

    num: NDArray[Any]
    total: NDArray[Any]

    def floored(self, min_sum: float) -> NDArray[np.float32]:
        """(h, w) float32 ``num / max(total, min_sum)`` (``min_sum`` [DN])."""
        if self.num.dtype == np.int16:  # blue clay: the floor in whole DN, as ever
            total = np.maximum(self.total, np.int16(min_sum))
            return np.asarray(cv2.divide(self.num, total, scale=1.0, dtype=cv2.CV_32F),
                              np.float32)
        total = np.maximum(self.total, np.float32(min_sum))
        return np.asarray(cv2.divide(self.num, total), np.float32)


def blue_parts(image: NDArray[np.uint8]) -> ChromaParts:
    """Blue clay's ``(B - R, B + G + R)`` of a BGR image (h, w, 3), int16 each."""
    b, g, r = cv2.split(image)
    diff = cv2.subtract(b, r, dtype=cv2.CV_16S)
    total = cv2.add(cv2.add(b, g, dtype=cv2.CV_16S), r, dtype=cv2.CV_16S)
    return ChromaParts(np.asarray(diff, np.int16), np.asarray(total, np.int16))


def axis_numerator(pixels: NDArray[np.float32], axis: NDArray[np.float32],
                   ) -> NDArray[np.float32]:
    """(h, w) float32 ``axis . [B, G, R]`` of a float32 BGR image (h, w, 3)."""
    return np.asarray(cv2.transform(pixels, axis.reshape(1, 3)), np.float32)


def axis_parts(pixels: NDArray[np.float32], axis: NDArray[np.float32],
               num: NDArray[np.float32] | None = None) -> ChromaParts:
    """Another clay's ``(axis . [B, G, R], B + G + R)`` of a float32 BGR image (h, w, 3);
    ``num``: its numerator when already computed (:func:`axis_numerator`, the same values)."""
    if num is None:
        num = axis_numerator(pixels, axis)
    total = np.asarray(cv2.transform(pixels, np.ones((1, 3), np.float32)), np.float32)
    return ChromaParts(num, total)


def axis_chroma(image: NDArray[np.uint8], axis: NDArray[np.float32],
                min_sum: float) -> NDArray[np.float32]:
    """(h, w) float32 ``(axis . [B, G, R]) / max(B + G + R, min_sum)`` of a BGR image
    (``min_sum`` [DN])."""
    return axis_parts(image.astype(np.float32), axis).floored(min_sum)


def axis_bound(num: NDArray[np.float32], level: float) -> NDArray[np.uint8]:
    """(h, w) uint8: 255 where the numerator ``num`` (:func:`axis_numerator`) exceeds ``level``
    [DN] (every pixel whose chroma can exceed ``level / floor``), else 0."""
    return np.asarray((num > level).view(np.uint8) * np.uint8(255), np.uint8)
