"""Splitting touching markers: a blob of marker colour larger than one marker is fitted with two
or three discs of the marker's known size.

Markers bunched in front of a tine touch or overlap in the image (on a re-rendered run 18 pairs
closer than 12 mm in one pass, 6-7 px apart for an 8 px marker). The detector's matched filter
then finds one peak between them, or two whose centroid windows each take in part of the other
marker: measured on synthetic pairs of 8 px markers, one detection 2.5-4.8 px from both centres
at 5-7 px apart, two detections pulled 0.6-1.8 px towards each other at 8 px. A track following
such a spot hops from one marker to its neighbour.

Both markers are the same clay, and the chroma ``(B - R) / (B + G + R)`` is the same everywhere on
a marker (shading cancels), so the chroma image of touching markers is the *union* of their discs
at one level, not the sum of two bumps. The model of a connected blob of ``k`` markers is

    c(x) = b + A * (1 - prod_i (1 - f_i(x))),   f_i(x) = 1/2 erfc((|x - x_i| - r) / (sqrt(2) s))

a union of ``k`` discs of the radius ``r`` the calibration and the markers' depth give (a disc
with an edge blurred by ``s``: JPEG's half-resolution chroma and the optics), above the sand's
level ``b``. It is fitted to the blob's pixels with ``scipy.optimize.least_squares`` (centres,
``A``, ``b``; ``r`` within 70-115 % of the expected radius, since depth and burial change it).
The count is decided by the fit: ``k + 1`` discs replace ``k`` only when they lower the squared
residual by ``GAIN`` times, every pair of centres is at least ``MIN_SEPARATION`` radii apart, and
every disc shows at least ``MIN_OWN_SHARE`` of a disc of its own (pixels it covers that no other
disc does); and a blob is fitted at all only when its area exceeds ``AREA_RATIO`` single
markers or it holds more than one detector peak. A blob decided to be one marker keeps the
detector's own centroid.

Which blobs are tried and the model are measured against synthetic pairs (``spots`` in the tests)
and tuning renders of another run; the held-out recordings were not used to choose them.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from scipy.special import erfc

FloatArray = NDArray[np.float64]
AREA_RATIO = 1.45  # a blob larger than this many single-marker footprints is tried as several
GAIN = 2.0  # k + 1 discs must lower the squared residual this many times to be believed
MIN_SEPARATION = 0.9  # fitted centres closer than this many radii are one marker
MIN_OWN_SHARE = 0.2  # each fitted disc must show this share of a disc that no other disc covers
MAX_MARKERS = 3  # most markers one blob is split into
EDGE_BLUR = 0.6  # edge blur s of the model [detector px] (JPEG chroma at half resolution)
RADIUS_SPREAD = 0.1  # the prior's standard deviation of the radius, as a share of it
MARGIN = 2  # pixels fitted around a blob's bounding box [detector px]


@dataclass(frozen=True)
class BlobFit:
    """A blob's fitted markers.

    Attributes:
        centres: (k, 2) disc centres [detector px, window coordinates].
        level: the markers' chroma above the sand's [-].
        cost: the fit's squared residual.
    """

    centres: FloatArray
    level: float
    cost: float


def disc_union(xy: FloatArray, centres: FloatArray, radius: float, blur: float) -> FloatArray:
    """(n,) the union of discs at ``centres`` (k, 2) with blurred edges, sampled at ``xy`` (n, 2):
    1 inside any disc, 0 far from all."""
    rho = np.linalg.norm(xy[:, None, :] - centres[None, :, :], axis=2)
    inside = 0.5 * erfc((rho - radius) / (np.sqrt(2.0) * blur))
    return np.asarray(1.0 - np.prod(1.0 - inside, axis=1), np.float64)


def fit_discs(patch: NDArray[np.float32], origin: tuple[int, int], start: FloatArray,
              radius: float) -> BlobFit:
    """Least-squares fit of ``len(start)`` touching discs to a chroma ``patch``
    (Levenberg-Marquardt, ``scipy.optimize.least_squares(method='lm')``, analytic Jacobian).

    The radius is held near the expected one by a prior residual (``RADIUS_SPREAD``), so a
    disc cannot grow over two markers.

    Args:
        patch: (h, w) chroma around the blob.
        origin: (x0, y0) of the patch in window coordinates [detector px].
        start: (k, 2) initial centres [detector px, window coordinates].
        radius: expected disc radius [detector px].
    """
    h, w = patch.shape
    yy, xx = np.mgrid[0:h, 0:w]
    xy = np.column_stack([xx.ravel() + origin[0], yy.ravel() + origin[1]]).astype(np.float64)
    values = patch.ravel().astype(np.float64)
    k = len(start)
    low, high = float(np.percentile(values, 10)), float(values.max())
    level = max(high - low, 1e-3)
    spread = RADIUS_SPREAD * radius / level  # the prior's weight against a pixel's residual

    def parts(p: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        diff = xy[:, None, :] - p[3:].reshape(k, 2)[None]  # (n, k, 2)
        rho = np.sqrt((diff ** 2).sum(2)) + 1e-9
        t = (rho - p[2]) / (np.sqrt(2.0) * EDGE_BLUR)
        inside = 0.5 * erfc(t)
        edge = np.exp(-t * t) / (np.sqrt(2.0 * np.pi) * EDGE_BLUR)  # d inside / d radius
        return diff, rho, inside, edge

    def residual(p: FloatArray) -> FloatArray:
        inside = parts(p)[2]
        model = p[1] + p[0] * (1.0 - np.prod(1.0 - inside, axis=1))
        return np.concatenate([model - values, [(p[2] - radius) / spread]])

    def jacobian(p: FloatArray) -> FloatArray:
        diff, rho, inside, edge = parts(p)
        outside = 1.0 - inside
        others = np.stack([np.prod(np.delete(outside, i, axis=1), axis=1) for i in range(k)],
                          axis=1)  # (n, k): no other disc covers the pixel
        jac = np.zeros((len(values) + 1, 3 + 2 * k))
        jac[:-1, 0] = 1.0 - np.prod(outside, axis=1)
        jac[:-1, 1] = 1.0
        jac[:-1, 2] = p[0] * (others * edge).sum(1)
        pull = p[0] * others * edge / rho  # (n, k)
        jac[:-1, 3::2] = pull * diff[:, :, 0]
        jac[:-1, 4::2] = pull * diff[:, :, 1]
        jac[-1, 2] = 1.0 / spread
        return jac

    p0 = np.concatenate([[level, low, radius], start.ravel()])
    fit = least_squares(residual, p0, jac=jacobian, method='lm', max_nfev=20 * (k + 1),
                        xtol=1e-4, ftol=1e-4)
    return BlobFit(fit.x[3:].reshape(k, 2), float(fit.x[0]), float(2 * fit.cost))


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


def _own_share(centres: FloatArray, xy: FloatArray, radius: float) -> float:
    """The smallest share of a disc's area that only that disc covers, over the discs."""
    inside = np.linalg.norm(xy[:, None, :] - centres[None], axis=2) <= radius
    own = (inside & (inside.sum(1) == 1)[:, None]).sum(0)
    return float(own.min() / (np.pi * radius ** 2))


def _accept(fit: BlobFit, better: BlobFit, xy: FloatArray, radius: float) -> bool:
    """Whether ``better`` (one disc more) is believed over ``fit``."""
    c = better.centres
    gaps = np.linalg.norm(c[:, None] - c[None], axis=2)[np.triu_indices(len(c), 1)]
    return bool(better.cost * GAIN < fit.cost and gaps.min() >= MIN_SEPARATION * radius
                and _own_share(c, xy, radius) >= MIN_OWN_SHARE)


def split_blob(patch: NDArray[np.float32], origin: tuple[int, int], base: float,
               radius: float) -> FloatArray | None:
    """(k, 2) centres of the k >= 2 markers a blob holds, or None when it is one marker.

    Args:
        patch: (h, w) chroma around the blob (the blob and ``MARGIN`` pixels of sand).
        origin: (x0, y0) of the patch in window coordinates [detector px].
        base: chroma above which a pixel belongs to a marker [-].
        radius: expected marker radius [detector px].
    """
    h, w = patch.shape
    yy, xx = np.mgrid[0:h, 0:w]
    xy = np.column_stack([xx.ravel() + origin[0], yy.ravel() + origin[1]]).astype(np.float64)
    wgt = np.maximum(patch.ravel().astype(np.float64) - base, 0.0)
    if wgt.sum() <= 0:
        return None
    area = float((wgt > 0).sum())
    mean = (wgt[:, None] * xy).sum(0) / wgt.sum()
    best = fit_discs(patch, origin, mean[None], radius)
    chosen: FloatArray | None = None
    for k in range(2, MAX_MARKERS + 1):
        if area < (k - 1) * np.pi * radius ** 2:
            break  # no room for another marker
        trial = fit_discs(patch, origin, _along_axis(xy, wgt, k), radius)
        if not _accept(best, trial, xy[wgt > 0], radius):
            break
        best, chosen = trial, trial.centres
    return chosen


def split_touching(chroma: NDArray[np.float32], uv: FloatArray, base: float, radius: float,
                   ) -> tuple[FloatArray, NDArray[np.intp], NDArray[np.bool_]]:
    """Markers of a chroma window with touching ones split apart.

    Args:
        chroma: (h, w) the detector's chroma window.
        uv: (n, 2) the detector's centres [detector px, window coordinates] (NaN: none).
        base: chroma above which a pixel belongs to a marker [-].
        radius: expected marker radius [detector px].

    Returns:
        ``(uv, source, split)``: (m, 2) centres with each split blob's detections replaced by
        its fitted markers, (m,) the index in ``uv`` each came from (the blob's first
        detection for a split one), in the order of ``uv``, and (m,) whether it is a fitted
        marker of a split blob.
    """
    mask = (chroma > base).view(np.uint8)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    ok = np.isfinite(uv).all(axis=1)
    h, w = chroma.shape
    cols = np.clip(np.rint(np.where(ok, uv[:, 0], 0)), 0, w - 1).astype(int)
    rows = np.clip(np.rint(np.where(ok, uv[:, 1], 0)), 0, h - 1).astype(int)
    label = np.where(ok, labels[rows, cols], 0)
    single = np.pi * radius ** 2
    out: list[FloatArray] = []
    source: list[int] = []
    split: list[bool] = []
    done: set[int] = set()
    for i in range(len(uv)):
        lab = int(label[i])
        if lab in done:
            continue
        members = np.flatnonzero(label == lab) if lab > 0 else np.array([i])
        if lab > 0 and (stats[lab, cv2.CC_STAT_AREA] > AREA_RATIO * single
                        or len(members) > 1):
            done.add(lab)
            x, y, bw, bh = stats[lab, :4]
            x0, y0 = max(x - MARGIN, 0), max(y - MARGIN, 0)
            x1, y1 = min(x + bw + MARGIN, w), min(y + bh + MARGIN, h)
            patch = np.where(labels[y0:y1, x0:x1] == lab, chroma[y0:y1, x0:x1],
                             np.minimum(chroma[y0:y1, x0:x1], base))
            centres = split_blob(patch, (x0, y0), base, radius)
            if centres is not None:
                out += list(centres)
                source += [int(members[0])] * len(centres)
                split += [True] * len(centres)
                continue
            out += [uv[j] for j in members]
            source += members.tolist()
            split += [False] * len(members)
            continue
        out.append(uv[i])
        source.append(i)
        split.append(False)
    return (np.array(out, np.float64).reshape(-1, 2), np.array(source, np.intp),
            np.array(split, bool))
