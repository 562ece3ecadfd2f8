"""Touching markers the sand partly covers, split by discs cut along the image's up direction
(``tracking.cut_discs``, ``DetectorConfig.cut_split`` and ``split_wide``)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spots import cut_disc_patch, spot_image

from dempath_recon.tracking.cut_discs import (
    EDGE_BLUR,
    fit_cut_discs,
    pixel_grid,
    union_jacobian,
    union_model,
)
from dempath_recon.tracking.cut_discs_kernel import residual_and_jacobian
from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector

SHAPE = (240, 320)
RADIUS = 4.0  # px: an 8 px marker, as on the tuning re-renders
UP = (0.0, -1.0)  # world up is up the image (spots.py buries a marker's lower part)


def detector(**kw: object) -> MarkerDetector:
    """A detector that knows the marker size, the up direction and a low view (30 degrees)."""
    return MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS, up_px=UP,
                                         view_elevation_deg=30.0, **kw))  # type: ignore[arg-type]


def nearest(found: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(n,) distance of each true centre to its nearest point [px]."""
    if not len(found):
        return np.full(len(truth), np.inf)
    return np.linalg.norm(truth[:, None] - found[None], axis=2).min(axis=1)


def covered_beside_whole(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Two touching markers 6-7.5 px apart side by side, the second 45 % buried, and a lone
    whole marker: centres (3, 2) px and burial (3,)."""
    a = np.array([100.0, 80.0]) + rng.uniform(0, 1, 2)
    gap = rng.uniform(6.0, 7.5)
    truth = np.array([a, a + np.array([gap, rng.uniform(-1, 1)]), [220.0, 160.0]])
    return truth, np.array([0.0, 0.45, 0.0])


@pytest.mark.parametrize('off', [{'cut_split': False}, {'split_wide': False}])
def test_a_covered_marker_touching_a_whole_one_is_split_at_both_centres(
        off: dict[str, bool]) -> None:
    """A marker 45 % buried touching a whole one (a blob no larger than about one and a half
    markers): two parted markers published within 1 px of their centres (on average under
    0.8 px); whole discs or only large blobs tried leave one spot between them, 5-7 px off."""
    rng = np.random.default_rng(3)
    cut, plain = detector(), detector(**off)
    errors, plain_worst = [], 0.0
    for _ in range(6):
        truth, buried = covered_beside_whole(rng)
        jpeg = spot_image(SHAPE, truth, RADIUS, rng, buried=buried)
        found = cut.detect_jpeg(jpeg)
        assert len(found.uv) == 3
        assert found.parted is not None and found.centre is not None
        assert found.parted.sum() == 2
        assert not found.parted[np.argmin(nearest(truth[2:], found.uv[:, None])[:, 0])]
        errors.append(nearest(found.centre, truth[:2]))
        plain_worst = max(plain_worst, float(nearest(plain.detect_jpeg(jpeg).uv, truth).max()))
    assert np.max(errors) < 1.0
    assert np.mean(errors) < 0.8
    assert plain_worst > 4.0


def test_lone_covered_markers_stay_single() -> None:
    """Lone markers 30-55 % buried among whole ones are never split, whatever blobs are tried:
    the cut disc fits them as one marker."""
    rng = np.random.default_rng(5)
    det = detector()
    for _ in range(6):
        truth = np.array([[100.0, 80.0], [220.0, 160.0], [60.0, 180.0], [260.0, 60.0],
                          [160.0, 200.0]]) + rng.uniform(0, 1, (5, 2))
        buried = np.array([rng.uniform(0.3, 0.55), rng.uniform(0.3, 0.55), 0.0, 0.0, 0.0])
        found = det.detect_jpeg(spot_image(SHAPE, truth, RADIUS, rng, buried=buried))
        assert len(found.uv) == 5
        assert found.parted is not None and not found.parted.any()


def test_one_marker_covering_another_gives_both_centres() -> None:
    """A marker hiding the lower part of the one behind it (5-6 px apart up the image): both
    published within 1 px of their centres (a guard: whole discs part this one too)."""
    rng = np.random.default_rng(9)
    det = detector()
    for _ in range(6):
        a = np.array([100.0, 80.0]) + rng.uniform(0, 1, 2)
        step = np.array([rng.uniform(-2, 2), rng.uniform(5.0, 6.0)])
        truth = np.array([a, a + step, [220.0, 160.0]])
        found = det.detect_jpeg(spot_image(SHAPE, truth, RADIUS, rng))
        assert len(found.uv) == 3
        assert found.centre is not None
        assert nearest(found.centre, truth).max() < 1.0


def test_steep_views_fit_whole_discs() -> None:
    """Above ``covered.MAX_ELEVATION_DEG`` the sand does not cut a chord: the split fits whole
    discs, as without ``cut_split``."""
    rng = np.random.default_rng(3)
    truth, buried = covered_beside_whole(rng)
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, buried=buried)

    def steep(cut: bool) -> np.ndarray:
        cfg = DetectorConfig(marker_diameter_px=2 * RADIUS, up_px=UP, view_elevation_deg=66.0,
                             cut_split=cut)
        return MarkerDetector(cfg).detect_jpeg(jpeg).uv

    assert np.array_equal(steep(True), steep(False))


def test_the_jacobian_is_the_models_derivative() -> None:
    """``union_jacobian`` equals central differences of ``union_model`` (two cut discs and two
    whole ones)."""
    xy = pixel_grid((14, 18), (3, 4))
    up = np.array([0.6, -0.8])
    for p, cut in ((np.array([0.6, -0.1, 4.2, 9.0, 10.0, -1.5, 14.5, 11.0, 0.8]), up),
                   (np.array([0.6, -0.1, 4.2, 9.0, 10.0, 14.5, 11.0]), None)):
        jac = union_jacobian(p, xy, 2, cut)
        for j in range(len(p)):
            step = np.zeros_like(p)
            step[j] = 1e-6
            ahead, back = union_model(p + step, xy, 2, cut), union_model(p - step, xy, 2, cut)
            numeric = (ahead - back) / 2e-6
            assert np.allclose(jac[:, j], numeric, atol=1e-6), j


def test_the_compiled_kernel_is_the_reference_model() -> None:
    """``residual_and_jacobian`` (the fit's compiled path) gives ``union_model`` less the values
    and ``union_jacobian``, then the radius prior, to rounding: one, two and three discs, cut
    and whole."""
    rng = np.random.default_rng(5)
    xy = pixel_grid((15, 21), (2, 3))
    up = np.array([0.6, -0.8])
    values = rng.normal(0.2, 0.1, len(xy))
    for k in (1, 2, 3):
        for cut in (up, None):
            per = 2 if cut is None else 3
            discs = np.column_stack([rng.uniform(6, 18, k), rng.uniform(6, 14, k)]
                                    + ([rng.uniform(-5, 2, k)] if cut is not None else []))
            p = np.concatenate([[0.55, -0.12, 4.1], discs.ravel()])
            res, jac = np.empty(len(xy) + 1), np.empty((len(xy) + 1, 3 + per * k))
            residual_and_jacobian(p, xy, k, up, cut is not None, EDGE_BLUR, values, 4.0, 0.2,
                                  res, jac)
            assert np.allclose(res[:-1], union_model(p, xy, k, cut) - values, atol=1e-12)
            assert np.allclose(jac[:-1], union_jacobian(p, xy, k, cut), atol=1e-12)
            assert res[-1] == pytest.approx((4.1 - 4.0) / 0.2)
            assert jac[-1, 2] == pytest.approx(1 / 0.2) and not jac[-1, [0, 1, 3]].any()


def test_a_cut_disc_fit_finds_the_centre_below_the_seen_part() -> None:
    """A disc of radius 4 with its lower 40 % hidden (chord 0.2 radii below the centre), drawn
    8x supersampled: the fit puts its centre within 0.15 px and the chord within 0.1 radii,
    where the seen part's middle lies 1.3 px up."""
    centre, r, t = np.array([12.3, 10.6]), 4.0, -0.2
    xy = pixel_grid((22, 24), (0, 0))
    sub = (np.arange(8) + 0.5) / 8 - 0.5
    ox, oy = np.meshgrid(sub, sub)
    pts = xy[:, None, :] + np.column_stack([ox.ravel(), oy.ravel()])[None]
    d = pts - centre
    seen = (np.hypot(d[..., 0], d[..., 1]) <= r) & (-d[..., 1] >= t * r)
    patch = (-0.2 + 0.7 * seen.mean(1)).reshape(22, 24).astype(np.float32)
    fit = fit_cut_discs(patch, (0, 0), np.array([[12.3, 9.3]]), r, np.array([0.0, -1.0]))
    assert np.linalg.norm(fit.centres[0] - centre) < 0.15
    assert abs(fit.cuts[0] - t) < 0.1


@pytest.mark.parametrize('up', [None, (0.0, -1.0)])
def test_a_fit_does_not_depend_on_where_its_window_begins(up: tuple[float, float] | None) -> None:
    """Two touching markers (one 30 % buried), the same chroma patch placed at the frame's
    corner and at (1500, 900): the fitted centres move by exactly the placement. MINPACK's
    stopping test is relative to the parameters' size, and a fit in window coordinates stopped
    coarser far from the origin: the windowed and the whole-frame detector differed by up to
    0.97 px on real renders."""
    r = 4.0
    centres = np.array([[12.4, 11.2], [19.1, 12.0]])
    patch = cut_disc_patch((24, 32), centres, (-1.0, -0.4), r)
    start = centres + np.array([[-0.8, 0.6], [0.7, -0.5]])
    direction = None if up is None else np.asarray(up)
    near = fit_cut_discs(patch, (0, 0), start, r, direction)
    shift = np.array([1500.0, 900.0])
    far = fit_cut_discs(patch, (1500, 900), start + shift, r, direction)
    assert np.allclose(far.centres - shift, near.centres, atol=1e-9)
    assert np.allclose(far.cuts, near.cuts, atol=1e-9)
    if up is not None:  # whole discs put the buried marker on its seen part, by design
        assert np.linalg.norm(near.centres - centres, axis=1).max() < 0.3
