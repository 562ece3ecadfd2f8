"""Detection across looks: sand and clay colours, half-buried markers (real OpenCV, JPEG)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector

SHAPE = (240, 320)
REDDISH_SAND = np.array([0.30, 0.50, 0.75])  # BGR albedo: sand chroma about -0.3
DARK_CLAY = np.array([0.55, 0.25, 0.15])


def centres(rng: np.random.Generator) -> np.ndarray:
    """(35, 2) well separated centres [px] with random sub-pixel offsets."""
    gx, gy = np.meshgrid(np.arange(30, 300, 40), np.arange(30, 220, 40))
    return np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-5, 5, (gx.size, 2))


def found_share(config: DetectorConfig, sand_bgr: np.ndarray, buried: float, seed: int) -> float:
    """Share of half-buried 8.4 px markers found within 3 px of the centre of their visible
    part."""
    rng = np.random.default_rng(seed)
    truth = centres(rng)
    radius = 4.2
    jpeg = spot_image(SHAPE, truth, radius, rng, sand_bgr=sand_bgr, clay_bgr=DARK_CLAY,
                      buried=buried, noise_dn=2.0, quality=85)
    det = MarkerDetector(config).detect_jpeg(jpeg)
    visible = truth - [0.0, radius * buried]  # the visible cap's middle, roughly
    if not len(det.uv):
        return 0.0
    d = np.linalg.norm(det.uv[None] - visible[:, None], axis=2).min(axis=1)
    return float(np.mean(d < 3.0))


@pytest.mark.parametrize('sand_bgr', [REDDISH_SAND, np.array([0.42, 0.58, 0.72])])
def test_half_buried_markers_are_found_whatever_the_sands_hue(sand_bgr: np.ndarray) -> None:
    """A marker 45 % buried (55 % of its disc seen) is found on reddish sand as on yellow
    sand: the matched filter sees sand no redder than the threshold assumes, so the sand's more
    negative chroma cannot pull the spot's filtered peak further down."""
    share = found_share(DetectorConfig(), sand_bgr, 0.45, seed=3)
    assert share > 0.75, f'found {share:.0%} of the half-buried markers'


def test_without_the_floor_reddish_sand_hides_half_buried_markers() -> None:
    """The rule matters: with the filter on raw chroma many half-buried markers on reddish
    sand are lost (what the session-14 held-out reddish look showed)."""
    share = found_share(DetectorConfig(floor_sand=False), REDDISH_SAND, 0.45, seed=3)
    assert share < 0.65, f'found {share:.0%} without the floor'


def test_bare_reddish_and_grey_sand_give_no_spot() -> None:
    """No spot in bare sand of any hue, noisy, with the floor."""
    for albedo, noise in ((REDDISH_SAND, 4.0), (np.array([0.55, 0.58, 0.60]), 6.0)):
        rng = np.random.default_rng(5)
        jpeg = spot_image(SHAPE, np.zeros((0, 2)), 4.0, rng, sand_bgr=albedo, noise_dn=noise,
                          quality=60)
        assert len(MarkerDetector().detect_jpeg(jpeg).uv) == 0, albedo
