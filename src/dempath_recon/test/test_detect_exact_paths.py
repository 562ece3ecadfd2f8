"""The detector's shortcuts give exactly what the plain computation gives: the cut-disc fit
without scipy's ``leastsq`` wrapper, the low decile without ``np.percentile``, the blobs of a
window labelled only around its detections, and the 5 x 5 brightness of many peaks at once."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.optimize import leastsq

sys.path.insert(0, str(Path(__file__).parent))
from spots import cut_disc_patch

from dempath_recon.tracking.colour_model import patch_brightness
from dempath_recon.tracking.cut_discs import (
    EDGE_BLUR,
    RADIUS_SPREAD,
    fit_cut_discs,
    low_decile,
    pixel_grid,
)
from dempath_recon.tracking.cut_discs_kernel import residual_and_jacobian
from dempath_recon.tracking.split import blob_labels


def drawn_pair(rng: np.random.Generator, shape: tuple[int, int], r: float,
               ) -> tuple[np.ndarray, np.ndarray]:
    """A chroma patch (h, w) float32 of two touching discs of radius ``r`` (the second 30 %
    buried, 8x supersampled, with noise) and their centres (2, 2) px."""
    h, w = shape
    a = np.array([w / 2 - 3.2, h / 2]) + rng.uniform(-0.5, 0.5, 2)
    centres = np.array([a, a + np.array([rng.uniform(5.5, 7.5), rng.uniform(-1, 1)])])
    patch = cut_disc_patch(shape, centres, (-1.0, -0.4), r) + rng.normal(0, 0.02, shape)
    return patch.astype(np.float32), centres


def leastsq_fit(patch: np.ndarray, start: np.ndarray, r: float, up: np.ndarray | None,
                ) -> tuple[np.ndarray, float]:
    """The fit as session 20 made it: scipy's ``leastsq`` (full output) over the compiled
    kernel from the same start: the parameters and the squared residual."""
    xy = pixel_grid(patch.shape, (0, 0))
    values = patch.ravel().astype(np.float64)
    k, per = len(start), 2 if up is None else 3
    low = float(np.percentile(values, 10))
    level = max(float(values.max()) - low, 1e-3)
    spread = RADIUS_SPREAD * r / level
    res, jac = np.empty(len(values) + 1), np.empty((len(values) + 1, 3 + per * k))
    direction = np.zeros(2) if up is None else up

    def residual(p: np.ndarray) -> np.ndarray:
        residual_and_jacobian(p, xy, k, direction, up is not None, EDGE_BLUR, values, r,
                              spread, res, jac)
        return res.copy()

    def jacobian(p: np.ndarray) -> np.ndarray:
        residual_and_jacobian(p, xy, k, direction, up is not None, EDGE_BLUR, values, r,
                              spread, res, jac)
        return jac.copy()

    first = start if up is None else np.column_stack([start, np.full(k, -r)])
    p0 = np.concatenate([[level, low, r], first.ravel()])
    x, _, info, _, _ = leastsq(residual, p0, Dfun=jacobian, full_output=True, ftol=1e-4,
                               xtol=1e-4, gtol=1e-8, maxfev=20 * (k + 1) * (per - 1))
    return x, float(np.dot(info['fvec'], info['fvec']))


@pytest.mark.parametrize('up', [None, (0.0, -1.0)])
def test_the_fit_is_scipys_leastsq_to_the_last_bit(up: tuple[float, float] | None) -> None:
    """Two touching markers (one 30 % buried) in ten noisy patches, fitted as one, two and
    three discs: the centres, cuts, radius, level and cost equal those of ``leastsq`` over the
    same kernel exactly (the same MINPACK, called without its wrapper)."""
    rng = np.random.default_rng(21)
    direction = None if up is None else np.asarray(up, np.float64)
    for _ in range(10):
        patch, centres = drawn_pair(rng, (22, 30), 4.0)
        for k in (1, 2, 3):
            start = centres.mean(0) + np.linspace(-2.5, 2.5, k)[:, None] * [1.0, 0.1]
            fit = fit_cut_discs(patch, (0, 0), start, 4.0, direction)
            x, cost = leastsq_fit(patch, start, 4.0, direction)
            per = 2 if up is None else 3
            q = x[3:].reshape(k, per)
            assert np.array_equal(fit.centres, q[:, :2])
            assert fit.radius == x[2] and fit.level == x[0] and fit.cost == cost
            if up is not None:
                assert np.array_equal(fit.cuts, np.maximum(q[:, 2] / max(x[2], 1e-6), -1.0))


def test_the_low_decile_is_numpys_percentile() -> None:
    """``low_decile`` equals ``np.percentile(values, 10)`` bit for bit, for 1 to 700 values,
    with ties and without."""
    rng = np.random.default_rng(3)
    for n in range(1, 701):
        for values in (rng.normal(size=n), rng.integers(-4, 4, n) * 0.05):
            assert low_decile(values) == float(np.percentile(values, 10))


def test_blobs_labelled_around_the_detections_are_the_whole_windows() -> None:
    """A window whose far corners hold blobs, two markers mid-window and a streak from one of
    them running far past the detections' box: each detection's blob has the same pixels and
    stats as when the whole window is labelled (the streak's blob leaves the box, and the
    whole window is labelled again); with the streak cut short, only the box is labelled
    (the corner blobs are 0)."""
    rng = np.random.default_rng(9)
    chroma = rng.uniform(-0.25, -0.1, (300, 400)).astype(np.float32)
    for x, y in ((5, 5), (390, 290), (395, 8)):
        chroma[y - 2:y + 3, x - 2:x + 3] = 0.4
    yy, xx = np.mgrid[0:300, 0:400]
    for cx, cy in ((150.3, 140.6), (160.1, 142.2)):
        chroma[np.hypot(xx - cx, yy - cy) <= 4.0] = 0.45
    rows, cols = np.array([141, 142]), np.array([150, 160])
    for streak, boxed in ((slice(160, 300), False), (slice(160, 166), True)):
        c = chroma.copy()
        c[141, streak] = 0.3  # a smear from the second marker to the right
        _, whole, whole_stats, _ = cv2.connectedComponentsWithStats(
            (c > 0.075).view(np.uint8), connectivity=8)
        labels, stats = blob_labels(c, 0.075, rows, cols, 10.0)
        for r, q in zip(rows, cols, strict=True):
            mine, ref = labels[r, q], whole[r, q]
            assert np.array_equal(labels == mine, whole == ref)
            assert np.array_equal(stats[mine], whole_stats[ref])
        assert (labels[5, 5] == 0) == boxed


def test_the_brightness_of_many_peaks_is_each_patchs_mean() -> None:
    """The 5 x 5 mean ``B + G + R`` of peaks anywhere in a frame, its edges and corners too,
    equals each patch's own mean (clipped at the image's edges) bit for bit."""
    rng = np.random.default_rng(2)
    image = rng.integers(0, 256, (37, 53, 3)).astype(np.uint8)
    rows = np.concatenate([rng.integers(0, 37, 200), [0, 0, 36, 36, 1]])
    cols = np.concatenate([rng.integers(0, 53, 200), [0, 52, 0, 52, 1]])
    each = [float(image[max(y - 2, 0):y + 3, max(x - 2, 0):x + 3].astype(np.float32)
                  .sum(axis=2).mean()) for y, x in zip(rows, cols, strict=True)]
    assert np.array_equal(patch_brightness(image, rows, cols), np.array(each))
    assert patch_brightness(image, rows[:0], cols[:0]).shape == (0,)


def numpy_centroids(c: np.ndarray, rows: np.ndarray, cols: np.ndarray, radius: float,
                    base: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The detector's iterated centroids as session 20 computed them, step by step in NumPy:
    uv (n, 2), size (n,), mass (n,)."""
    r = int(np.ceil(radius)) + 1
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1].astype(np.float64)
    h, w = c.shape
    pad = np.pad(c, r + 2, mode='edge')
    out, size, mass = np.full((len(rows), 2), np.nan), np.zeros(len(rows)), np.zeros(len(rows))
    for k, (y0, x0) in enumerate(zip(rows, cols, strict=True)):
        cx, cy = float(x0), float(y0)
        for _ in range(6):
            ix, iy = min(max(round(cx), 0), w - 1), min(max(round(cy), 0), h - 1)
            patch = pad[iy + 2:iy + 2 * r + 3, ix + 2:ix + 2 * r + 3].astype(np.float64)
            dx, dy = xx - (cx - ix), yy - (cy - iy)
            wgt = np.where(dx * dx + dy * dy <= radius ** 2, np.maximum(patch - base, 0.0), 0.0)
            total = wgt.sum()
            if total <= 0:
                break
            nx, ny = ix + (wgt * xx).sum() / total, iy + (wgt * yy).sum() / total
            moved = abs(nx - cx) + abs(ny - cy)
            cx, cy = nx, ny
            if moved < 0.01:
                break
        if 0 <= cx < w and 0 <= cy < h and total > 0:
            out[k] = cx, cy
            size[k] = np.sqrt((wgt * ((xx - (cx - ix)) ** 2 + (yy - (cy - iy)) ** 2)).sum()
                              / total)
            mass[k] = total
    return out, size, mass


def test_the_compiled_centroids_are_the_numpy_steps() -> None:
    """Spots of several sizes on noisy sand, some cut by the image's edges and corners, peaks
    on empty sand too: the compiled centroids, sizes and masses equal the NumPy steps' to
    1e-9 (the sums run in another order) and are NaN where theirs are."""
    from dempath_recon.tracking.centroid_kernel import refine_centroids

    rng = np.random.default_rng(11)
    c = rng.normal(-0.2, 0.05, (90, 130)).astype(np.float32)
    yy, xx = np.mgrid[0:90, 0:130]
    centres = [(1.9, 1.6), (129.2, 45.6), (64.3, 89.7), (40.6, 30.2), (80.1, 60.8), (100.5, 10.5)]
    for (cx, cy), r in zip(centres, (3.0, 4.2, 5.1, 2.6, 4.0, 3.5), strict=True):
        c[np.hypot(xx - cx, yy - cy) <= r] = rng.uniform(0.3, 0.6)
    rows = np.array([1, 46, 89, 30, 61, 10, 70, 5], np.intp)
    cols = np.array([1, 129, 64, 41, 80, 101, 20, 60], np.intp)  # the last two: bare sand
    for radius in (4.0, 5.5):
        half = int(np.ceil(radius)) + 1
        out, size, mass = np.full((8, 2), np.nan), np.zeros(8), np.zeros(8)
        refine_centroids(c, rows, cols, radius, half, 0.075, 6, 0.01, out, size, mass)
        ref = numpy_centroids(c, rows, cols, radius, 0.075)
        assert np.array_equal(np.isnan(out), np.isnan(ref[0]))
        assert np.isnan(out[6:]).all() and np.isfinite(out[3:6]).all()
        assert np.allclose(out, ref[0], atol=1e-9, equal_nan=True)
        assert np.allclose(size, ref[1], atol=1e-9) and np.allclose(mass, ref[2], rtol=1e-12)


def test_peaks_filtered_in_far_apart_clusters_are_the_whole_images() -> None:
    """Spots mid-frame and specks in three far corners of a 540x960 chroma (another clay's
    dark corners): the candidates fall in four clusters filtered apart, and the peaks are the
    local maxima of the matched filter over the whole image, in the same order."""
    from dempath_recon.tracking.detect import (
        FILTER_FLOOR,
        PEAK_TILE,
        DetectorConfig,
        MarkerDetector,
        candidate_groups,
    )

    rng = np.random.default_rng(6)
    c = rng.normal(-0.25, 0.04, (540, 960)).astype(np.float32)
    yy, xx = np.mgrid[0:540, 0:960]
    for cx, cy in rng.uniform([400, 230], [560, 310], (12, 2)):
        c[np.hypot(xx - cx, yy - cy) <= 4.0] = rng.uniform(0.3, 0.6)
    for x, y in ((4, 3), (955, 6), (950, 535)):
        c[y - 1:y + 2, x - 1:x + 2] = 0.2
    detector = MarkerDetector(DetectorConfig(downscale=2))
    rows, cols, fixed = detector._peaks(c, 0.15)
    assert fixed.all()  # no band-pass: every peak is the fixed rule's
    cand = np.argwhere(c > 0.15)
    assert len(candidate_groups(cand[:, 0], cand[:, 1], PEAK_TILE)) == 4
    smooth = cv2.GaussianBlur(np.maximum(c, np.float32(FILTER_FLOOR)), (0, 0),
                              detector._sigma)
    top = cv2.dilate(smooth, detector._kernel)
    r, q = cand[:, 0], cand[:, 1]
    keep = (smooth[r, q] >= top[r, q]) & (smooth[r, q] > 0.075)
    assert len(rows) >= 12
    assert np.array_equal(rows, r[keep]) and np.array_equal(cols, q[keep])


def test_making_a_detector_loads_its_compiled_kernels() -> None:
    """In a fresh process, making a ``MarkerDetector`` loads the centroid and cut-disc
    kernels (numba's first call, 0.2-0.35 s of CPU, falls on the node's start, not on its
    first frame), the cut-disc kernel in the fit's own specialisation too (a read-only pixel
    grid): a fit after it loads nothing more."""
    import os
    import subprocess
    import sys

    code = ('from dempath_recon.tracking.centroid_kernel import refine_centroids\n'
            'from dempath_recon.tracking.cut_discs_kernel import residual_and_jacobian\n'
            'from dempath_recon.tracking.detect import MarkerDetector\n'
            'before = len(refine_centroids.signatures) + len(residual_and_jacobian.signatures)\n'
            'MarkerDetector()\n'
            'made = len(residual_and_jacobian.signatures)\n'
            'import numpy as np\n'
            'from dempath_recon.tracking.cut_discs import fit_cut_discs\n'
            'fit_cut_discs(np.ones((9, 11), np.float32), (4, 3), np.array([[9.0, 7.0]]), 3.0,'
            ' np.array([0.0, -1.0]))\n'
            'print(before, len(refine_centroids.signatures), made,'
            ' len(residual_and_jacobian.signatures))\n')
    done = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          env=os.environ.copy(), timeout=120, check=True)
    assert done.stdout.split() == ['0', '1', '2', '2']


def test_the_nearest_past_position_is_the_first_nearest() -> None:
    """``MarkerPositions`` finds each marker's history entry nearest in time by bisection:
    for histories in order (with repeated stamps, and stamps halfway between two) and one
    that went back in time, the entry is the one ``min(past, key=|t - t_m|)`` gives, and
    ``carried`` moves a marker as with that search."""
    from dempath_recon.tracking.associate import MarkerPositions

    rng = np.random.default_rng(17)
    positions = MarkerPositions(0.005, 2.0)
    for marker in range(6):
        stamps = np.round(np.cumsum(rng.choice([0.0, 0.01, 0.02], 60)), 2)
        if marker == 5:
            stamps[30:] -= 0.25  # one history goes back in time
        for t in stamps:
            positions.accept(marker, float(t), rng.normal(0, 0.01, 3))
    for marker in range(6):
        past = positions.history[marker]
        for t_m in np.round(rng.uniform(-0.1, 1.4, 200), 3).tolist() + [p[0] for p in past]:
            want = min(range(len(past)), key=lambda i: abs(past[i][0] - t_m))
            assert positions._nearest(marker, t_m) == want
    assert not positions._ordered[5] and positions._ordered[0]
    placed = 0
    for marker in range(6):
        for stamp in (0.3, 0.9, 1.5):
            got = positions.carried(marker, stamp, 0.015, 1.0)
            want = carried_by_min(positions, marker, stamp, 0.015, 1.0)
            assert (got is None) == (want is None)
            assert got is None or np.array_equal(got, want)
            placed += got is not None
    assert placed >= 5


def carried_by_min(positions: object, marker: int, stamp_s: float, near_s: float,
                   recent_s: float) -> np.ndarray | None:
    """``MarkerPositions.carried`` as session 20 computed it (each neighbour's entry nearest in
    time found by ``min`` over its whole history), without an anchor."""
    known, history = positions.known, positions.history  # type: ignore[attr-defined]
    if marker not in known:
        return None
    t_m, x_m = known[marker]
    moves = []
    for n, past in history.items():
        now = known[n]
        if n == marker or stamp_s - now[0] > recent_s or now[0] <= t_m:
            continue
        then = min(past, key=lambda p: abs(p[0] - t_m))
        if abs(then[0] - t_m) <= near_s:
            moves.append((float(np.linalg.norm(then[1] - x_m)), now[1] - then[1]))
    if not moves:
        return None
    moves.sort(key=lambda mv: mv[0])
    return np.asarray(x_m + np.mean([mv[1] for mv in moves[:3]], axis=0), np.float64)
