"""Touching markers split by the fitted union of known-size discs (``tracking.split``)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector

SHAPE = (240, 320)
RADIUS = 4.0  # px: an 8 px marker, as the paper's 8 mm clay at about 0.9 m


def touching_pairs(rng: np.random.Generator, gap: float, n: int) -> list[np.ndarray]:
    """``n`` frames of two markers ``gap`` px apart at a random angle, one drawn over the other,
    and a lone marker elsewhere: (3, 2) px each."""
    out = []
    for _ in range(n):
        angle = rng.uniform(0, np.pi)
        a = np.array([100.0, 80.0]) + rng.uniform(0, 1, 2)
        out.append(np.array([a, a + gap * np.array([np.cos(angle), np.sin(angle)]),
                             [220.0 + rng.uniform(0, 1), 160.0]]))
    return out


def nearest(found: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(n,) distance of each true centre to its nearest detection [px]."""
    if not len(found):
        return np.full(len(truth), np.inf)
    return np.linalg.norm(truth[:, None] - found[None], axis=2).min(axis=1)


@pytest.mark.parametrize('gap', [5.0, 6.5, 8.0])
def test_touching_markers_are_split_with_accurate_centres(gap: float) -> None:
    """Two 8 px markers 5-8 px apart (overlapping: one partly covers the other): each found
    within 0.6 px, three detections in all; without the marker size the detector finds one
    spot between them (or two pulled together) more than 1 px off."""
    rng = np.random.default_rng(int(gap * 10))
    split = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS))
    plain = MarkerDetector(DetectorConfig())
    worst_split, worst_plain = 0.0, 0.0
    for truth in touching_pairs(rng, gap, 6):
        jpeg = spot_image(SHAPE, truth, RADIUS, rng)
        found = split.detect_jpeg(jpeg)
        assert len(found.uv) == 3
        worst_split = max(worst_split, float(nearest(found.uv, truth).max()))
        worst_plain = max(worst_plain, float(nearest(plain.detect_jpeg(jpeg).uv, truth).max()))
    assert worst_split < 0.6
    assert worst_plain > 1.0


def test_lone_markers_keep_the_detectors_own_centres() -> None:
    """Markers apart from each other are not refitted: the same centres with and without the
    marker size, and a marker half covered by sand stays one detection."""
    rng = np.random.default_rng(7)
    gx, gy = np.meshgrid(np.arange(30, 300, 40), np.arange(30, 220, 40))
    truth = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-5, 5, (gx.size, 2))
    jpeg = spot_image(SHAPE, truth, RADIUS, rng)
    split = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS)).detect_jpeg(jpeg)
    plain = MarkerDetector(DetectorConfig()).detect_jpeg(jpeg)
    assert len(split.uv) == len(truth)
    assert np.array_equal(split.uv, plain.uv)
    # a marker with a sand-coloured marker over its lower half (half buried): one spot
    half = np.array([[160.0, 120.0], [160.0, 124.5]])
    found = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS)).detect_jpeg(
        spot_image(SHAPE, half, RADIUS, rng, sand_coloured=(1,)))
    assert len(found.uv) == 1


def test_three_markers_in_a_row_give_three() -> None:
    """Three 8 px markers in a row 6.5 px apart (the bunch in front of a tine): three
    detections, each within 0.8 px."""
    rng = np.random.default_rng(11)
    for _ in range(4):
        angle = rng.uniform(0, np.pi)
        step = 6.5 * np.array([np.cos(angle), np.sin(angle)])
        a = np.array([150.0, 110.0]) + rng.uniform(0, 1, 2)
        truth = np.array([a - step, a, a + step])
        found = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS)).detect_jpeg(
            spot_image(SHAPE, truth, RADIUS, rng))
        assert len(found.uv) == 3
        assert nearest(found.uv, truth).max() < 0.8


def test_a_pair_left_in_one_spot_is_not_numbered() -> None:
    """Two 8 px markers 4.5 px apart left in one spot (its centre between them; only blobs
    larger than one marker tried for a split): its number is withheld; a lone marker's is
    kept."""
    from dempath_recon.tracking.stereo import withhold_crowded

    rng = np.random.default_rng(1)
    truth = np.array([[100.0, 80.0], [104.5, 80.5], [220.0, 160.0]])
    detector = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS, split_wide=False))
    found = detector.detect_jpeg(spot_image(SHAPE, truth, RADIUS, rng))
    assert len(found.uv) == 2
    lone = int(np.argmin(np.linalg.norm(found.uv - truth[2], axis=1)))
    markers = withhold_crowded(found, found.uv[::-1], np.array([4, 7], np.int32))
    assert markers.tolist() == ([4, -1] if lone == 1 else [-1, 7])
