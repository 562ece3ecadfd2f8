"""The bed floor: dusk markers judged against the bed around them (``exposure_floor='bed'``).

A marker's chroma ``(w . [B, G, R]) / max(B + G + R, floor)`` is divided down wherever its
``B + G + R`` lies under the floor (:mod:`~dempath_recon.tracking.colour_model`). At dusk a
marker sums 30-40 DN on a bed of 50-60 DN: the fixed floor (60) divides its chroma to 0.07-0.08
against the threshold 0.15, and the frame's median (``chroma_floor``) measures the ground
beyond the bin as well as the bed (on the twin's tiny scene 25-35 % darker than the bed beside
the markers), one floor for a frame that may hold light and shade. Here:

- :func:`bed_floor`: each pixel's floor is ``BED_SHARE`` of the bed's brightness around it
  (cells of ``BED_CELL`` pixels, the brightest nearby: the sand beside a marker, not the marker
  or a gap), never under ``BED_MIN_DN``;
- :func:`bed_candidates`: where on that floor a marker may pass the threshold (a byte bound);
- :func:`ring_sand_chroma`: the sand's chroma beside the markers found, from which the detector
  sets the bed search's threshold midway to the clay's (grey or pale sand lies nearer the clay
  than yellow-brown sand, and the noise of a dim pixel's chroma reaches the fixed threshold
  from it);

:meth:`~dempath_recon.tracking.detect.MarkerDetector._bed_spots` runs it and only adds markers
to the frame's own, kept as found (``detect.add_apart``); session 19 (track21) measured it and
left it off by default (docs/reconstruction.md).
"""

from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.colour_model import (
    DARK_SUM_DN,
    LIT_SHARE,
    MIN_SUM_DN,
    is_blue,
)

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

    def at_points(self, rows: NDArray[np.intp], cols: NDArray[np.intp]) -> NDArray[np.float32]:
        """(n,) float32 the floor at each pixel (``rows``, ``cols`` (n,)) [DN]."""
        ch, cw = self.cells.shape
        return np.asarray(self.cells[np.minimum(np.asarray(rows) // BED_CELL, ch - 1),
                                     np.minimum(np.asarray(cols) // BED_CELL, cw - 1)],
                          np.float32)

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
