"""Splitting touching markers: a blob of marker colour larger or wider than one marker is fitted
with two or three discs of the marker's known size, each cut by the sand in front of it.

Markers bunched in front of a tine touch or overlap in the image (on a re-rendered run 18 pairs
closer than 12 mm in one pass, 6-7 px apart for an 8 px marker). The detector's matched filter
then finds one peak between them, or two whose centroid windows each take in part of the other
marker: measured on synthetic pairs of 8 px markers, one detection 2.5-4.8 px from both centres
at 5-7 px apart, two detections pulled 0.6-1.8 px towards each other at 8 px. A track following
such a spot hops from one marker to its neighbour.

The model (:mod:`~dempath_recon.tracking.cut_discs`) is a union of ``k`` discs of the radius
the calibration and the markers' depth give, above the sand's level, each disc cut by the sand
in front of it along the image's up direction when that is known (``up``: from the
calibration, in views up to ``covered.MAX_ELEVATION_DEG``), whole otherwise. The count is
decided by the fit: ``k + 1`` markers replace ``k`` only when they lower the squared residual
by ``GAIN`` times, every pair of centres is at least ``MIN_SEPARATION`` radii apart, and every
marker shows at least ``MIN_OWN_SHARE`` of a disc of its own (seen pixels no other marker's
seen part covers). A blob is fitted at all only when its area exceeds ``AREA_RATIO`` single
markers, it holds more than one detector peak, or (``wide``) its radius of gyration exceeds
``WIDE_SIZE`` diameters. A blob decided to be one marker keeps the detector's own centroid; a
split blob's markers are given as the middle of each one's seen part (what the detector's
centroid of a lone marker measures, which the trackers and the numbering use) and their disc
centres (the published points, as ``covered`` gives for a lone marker).

Why cut discs: most merged misses on the tuning re-renders are pairs with one marker under
70 % visible (session 16, track7: 60 of 70 pairs 0.5-0.75 diameters apart), whose blob is no
larger than one and a half markers. With whole discs the one-marker fit of such a blob (or of
a lone covered marker) is poor and the two-disc fit puts one disc on the covered marker's seen
part, 3-3.5 px off: trying those blobs (radius of gyration over 0.38 diameters) raised switches
79 -> 82 and wrong-pair 3D points 4 -> 6 (session 16). A cut disc fits a lone covered marker
as one, and a covered pair as two at their centres.

Which blobs are tried and the model are measured against synthetic pairs (``spots`` in the tests)
and tuning renders of another run; the held-out recordings were not used to choose them.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache, partial

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.cut_discs import BlobFit, fit_cut_discs, pixel_grid

FloatArray = NDArray[np.float64]
AREA_RATIO = 1.45  # a blob larger than this many single-marker footprints is tried as several
GAIN = 2.0  # k + 1 discs must lower the squared residual this many times to be believed
EAGER_GAIN = 1.7  # the same with ``StereoTrackConfig.eager_split`` (off; session 25): blobs of
# touching markers 0.85-1.1 diameters apart (census of 15 burnt looks: half the merged
# marker-frames) were fitted 1.6-1.97 times better by two discs a diameter apart, each
# showing 0.4-0.65 of a disc of its own, and left whole; lone markers on the tuned variations
# (whole or covered, cut-disc fits) stay one at 1.7 (unchanged), 1.5 split pairs at dusk that
# then swapped (tuning looks Q193_dusk, Q197_lowsun)
MIN_SEPARATION = 0.9  # fitted centres closer than this many radii are one marker
MIN_OWN_SHARE = 0.2  # each fitted disc must show this share of a disc that no other disc covers
MAX_MARKERS = 3  # most markers one blob is split into
MARGIN = 2  # pixels fitted around a blob's bounding box [detector px]
WIDE_SIZE = 0.38  # with ``wide``, a blob whose radius of gyration exceeds this share of a
# marker's diameter is tried too (lone markers on the tuning renders: at most 0.39, 99 % below
# 0.35; detect.CROWDED_SIZE)


def _along_axis(xy: FloatArray, wgt: FloatArray, k: int) -> FloatArray:
    """(k, 2) ``k`` centres evenly spaced along the blob's long axis: for ``k`` equal discs a
    step ``d`` apart the weighted second moment along the axis exceeds the one across it by
    ``d^2 (k^2 - 1) / 12``."""
    total = wgt.sum()
    mean = (wgt[:, None] * xy).sum(0) / total
    diff = xy - mean
    cov = (wgt[:, None, None] * diff[:, :, None] * diff[:, None, :]).sum(0) / total
    vals, vecs = np.linalg.eigh(cov)
    step = np.sqrt(max(12.0 * (vals[1] - vals[0]) / (k * k - 1), 0.25))
    return np.asarray(mean + step * (np.arange(k) - (k - 1) / 2)[:, None] * vecs[:, 1],
                      np.float64)


def _own_share(fit: BlobFit, xy: FloatArray, up: FloatArray | None) -> float:
    """The smallest share of a whole disc's area that only that marker's seen part covers,
    over the markers."""
    seen = fit.seen(xy, up)
    own = (seen & (seen.sum(1) == 1)[:, None]).sum(0)
    return float(own.min() / (np.pi * fit.radius ** 2))


def _accept(fit: BlobFit, better: BlobFit, xy: FloatArray, radius: float,
            up: FloatArray | None, gain: float = GAIN) -> bool:
    """Whether ``better`` (one disc more) is believed over ``fit``: its squared residual
    ``gain`` times lower, its centres apart, each marker seen enough of its own."""
    c = better.centres
    gaps = np.linalg.norm(c[:, None] - c[None], axis=2)[np.triu_indices(len(c), 1)]
    return bool(better.cost * gain < fit.cost and gaps.min() >= MIN_SEPARATION * radius
                and _own_share(better, xy, up) >= MIN_OWN_SHARE)


def seen_centroid(fit: BlobFit, up: FloatArray | None) -> FloatArray:
    """(k, 2) the centroid of each fitted marker's seen part (the segment above its chord,
    side-on: ``2/3 (r^2 - h^2)^(3/2) / area`` up from the centre for a chord at height ``h``),
    which is what the detector's centroid of a lone marker measures."""
    if up is None:
        return fit.centres
    r = fit.radius
    h = np.clip(fit.cuts, -1.0, 0.999) * r
    area = r * r * np.arccos(h / r) - h * np.sqrt(r * r - h * h)
    lift = 2.0 / 3.0 * (r * r - h * h) ** 1.5 / area
    return np.asarray(fit.centres + lift[:, None] * up[None, :], np.float64)


def split_blob(patch: NDArray[np.float32], origin: tuple[int, int], base: float,
               radius: float, up: FloatArray | None = None, gain: float = GAIN,
               ) -> BlobFit | None:
    """The k >= 2 markers a blob holds, or None when it is one marker.

    Args:
        patch: (h, w) chroma around the blob (the blob and ``MARGIN`` pixels of sand).
        origin: (x0, y0) of the patch in window coordinates [detector px].
        base: chroma above which a pixel belongs to a marker [-].
        radius: expected marker radius [detector px].
        up: (2,) the image direction of world up: each disc cut by the sand in front of it
            (:mod:`~dempath_recon.tracking.cut_discs`), or None: whole discs.
        gain: how many times lower one more disc's squared residual must be (``GAIN``).
    """
    xy = pixel_grid(patch.shape, origin)
    wgt = np.maximum(patch.ravel().astype(np.float64) - base, 0.0)
    if wgt.sum() <= 0:
        return None
    area = float((wgt > 0).sum())
    mean = (wgt[:, None] * xy).sum(0) / wgt.sum()
    best = fit_cut_discs(patch, origin, mean[None], radius, up)
    chosen: BlobFit | None = None
    for k in range(2, MAX_MARKERS + 1):
        if area < (k - 1 - (0.5 if up is not None and k == 2 else 0.0)) * np.pi * radius ** 2:
            break  # no room for another marker (a covered pair may show one marker's area)
        trial = fit_cut_discs(patch, origin, _along_axis(xy, wgt, k), radius, up)
        if not _accept(best, trial, xy[wgt > 0], radius, up, gain):
            break
        best, chosen = trial, trial
    return chosen


def _tried(stats: NDArray[np.int32] | cv2.typing.MatLike, lab: int, members: int,
           gyration: Callable[[], float], radius: float, wide: bool) -> bool:
    """Whether blob ``lab`` may hold several markers: larger than ``AREA_RATIO`` markers, more
    than one detector peak in it, or (``wide``) a radius of gyration (``gyration()``, asked
    only then) above ``WIDE_SIZE`` diameters."""
    return bool(stats[lab, cv2.CC_STAT_AREA] > AREA_RATIO * np.pi * radius ** 2 or members > 1
                or (wide and gyration() > WIDE_SIZE * 2 * radius))


def blob_labels(chroma: NDArray[np.float32], base: float, rows: NDArray[np.intp],
                cols: NDArray[np.intp], reach: float,
                ) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    """The 8-connected blobs of the pixels of ``chroma`` (h, w) above ``base``: ``(labels,
    stats)`` as ``cv2.connectedComponentsWithStats`` gives them for the whole window, labelled
    at least where a blob holds one of the detections (``rows``, ``cols`` (n,) [px]).

    The window is the box of everything above the detector's threshold (on another clay's
    axis a vignetted view's dark corners spread it over half the frame) and only the blobs of
    the detections are read: they are labelled in the box of the detections grown by
    ``reach`` [px], and again over the whole window when one of them meets that box's edge
    (inside the window), where it may go on. Labels outside the box are 0; a blob's label
    and its stats' box are in window coordinates, its area its whole area.
    """
    h, w = chroma.shape
    if len(rows):
        grow = int(np.ceil(reach)) + 1
        x0, y0 = max(int(cols.min()) - grow, 0), max(int(rows.min()) - grow, 0)
        x1, y1 = min(int(cols.max()) + grow + 1, w), min(int(rows.max()) + grow + 1, h)
        if (x1 - x0) * (y1 - y0) < h * w:
            mask = (chroma[y0:y1, x0:x1] > base).view(np.uint8)
            _, part_cv, stats_cv, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
            part = np.asarray(part_cv, np.int32)
            stats = np.asarray(stats_cv, np.int32)
            mine = np.unique(part[rows - y0, cols - x0])
            mine = mine[mine > 0]
            sx, sy = stats[mine, cv2.CC_STAT_LEFT], stats[mine, cv2.CC_STAT_TOP]
            ex = sx + stats[mine, cv2.CC_STAT_WIDTH]
            ey = sy + stats[mine, cv2.CC_STAT_HEIGHT]
            cut = (((sx == 0) & (x0 > 0)) | ((sy == 0) & (y0 > 0))
                   | ((ex == x1 - x0) & (x1 < w)) | ((ey == y1 - y0) & (y1 < h)))
            if not cut.any():
                labels = np.zeros((h, w), np.int32)
                labels[y0:y1, x0:x1] = part
                stats[:, cv2.CC_STAT_LEFT] += x0
                stats[:, cv2.CC_STAT_TOP] += y0
                return labels, stats
    _, whole, whole_stats, _ = cv2.connectedComponentsWithStats(
        (chroma > base).view(np.uint8), connectivity=8)
    return np.asarray(whole, np.int32), np.asarray(whole_stats, np.int32)


def split_touching(chroma: NDArray[np.float32], uv: FloatArray, base: float, radius: float,
                   up: FloatArray | None = None, wide: bool = False, gain: float = GAIN,
                   ) -> tuple[FloatArray, NDArray[np.intp], NDArray[np.bool_], FloatArray]:
    """Markers of a chroma window with touching ones split apart.

    Args:
        chroma: (h, w) the detector's chroma window.
        uv: (n, 2) the detector's centres [detector px, window coordinates] (NaN: none).
        base: chroma above which a pixel belongs to a marker [-].
        radius: expected marker radius [detector px].
        up: (2,) the image direction of world up (each marker's disc cut by the sand in front
            of it), or None: whole discs.
        wide: also try blobs wider than one marker (``WIDE_SIZE``), not only large ones.
        gain: how many times lower one more disc's squared residual must be (``GAIN``;
            ``EAGER_GAIN`` with ``StereoTrackConfig.eager_split``).

    Returns:
        ``(uv, source, split, centre)``: (m, 2) centres with each split blob's detections
        replaced by its fitted markers (the middle of each one's seen part), (m,) the index in
        ``uv`` each came from (the blob's first detection for a split one), in the order of
        ``uv``, (m,) whether it is a fitted marker of a split blob, and (m, 2) the fitted
        markers' disc centres (``uv`` for the others).
    """
    ok = np.isfinite(uv).all(axis=1)
    h, w = chroma.shape
    cols = np.clip(np.rint(np.where(ok, uv[:, 0], 0)), 0, w - 1).astype(int)
    rows = np.clip(np.rint(np.where(ok, uv[:, 1], 0)), 0, h - 1).astype(int)
    labels, stats = blob_labels(chroma, base, rows[ok], cols[ok], 2.0 * radius + MARGIN)
    label = np.where(ok, labels[rows, cols], 0)
    out: list[FloatArray] = []
    centre: list[FloatArray] = []
    source: list[int] = []
    split: list[bool] = []
    done: set[int] = set()
    for i in range(len(uv)):
        lab = int(label[i])
        if lab in done:
            continue
        members = np.flatnonzero(label == lab) if lab > 0 else np.array([i])
        if lab > 0:
            done.add(lab)
            x, y, bw, bh = stats[lab, :4]
            x0, y0 = max(x - MARGIN, 0), max(y - MARGIN, 0)
            x1, y1 = min(x + bw + MARGIN, w), min(y + bh + MARGIN, h)
            inside = labels[y0:y1, x0:x1] == lab
            fit = None
            if _tried(stats, lab, len(members),
                      partial(_gyration, chroma[y0:y1, x0:x1], inside, base), radius, wide):
                patch = np.where(inside, chroma[y0:y1, x0:x1],
                                 np.minimum(chroma[y0:y1, x0:x1], base))
                fit = split_blob(patch, (x0, y0), base, radius, up, gain)
            if fit is not None:
                out += list(seen_centroid(fit, up))
                centre += list(fit.centres)
                source += [int(members[0])] * len(fit.centres)
                split += [True] * len(fit.centres)
                continue
        out += [uv[j] for j in members]
        centre += [uv[j] for j in members]
        source += members.tolist()
        split += [False] * len(members)
    return (np.array(out, np.float64).reshape(-1, 2), np.array(source, np.intp),
            np.array(split, bool), np.array(centre, np.float64).reshape(-1, 2))


def _gyration(patch: NDArray[np.float32], inside: NDArray[np.bool_], base: float) -> float:
    """A blob's radius of gyration [detector px], its chroma above ``base`` as the weight."""
    wgt = np.where(inside, np.maximum(patch - base, 0.0), 0.0).astype(np.float64)
    total = wgt.sum()
    if total <= 0:
        return 0.0
    yy, xx = _index_grid(*patch.shape)
    mx, my = (wgt * xx).sum() / total, (wgt * yy).sum() / total
    return float(np.sqrt((wgt * ((xx - mx) ** 2 + (yy - my) ** 2)).sum() / total))


@lru_cache(maxsize=256)
def _index_grid(h: int, w: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """``np.mgrid[0:h, 0:w]`` (rows, columns), read-only: a blob's patch is one of a few dozen
    shapes, and its gyration is asked of nearly every spot of a frame."""
    yy, xx = np.mgrid[0:h, 0:w]
    yy.flags.writeable = False
    xx.flags.writeable = False
    return yy, xx
