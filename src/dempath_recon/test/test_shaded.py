"""Published centres in dim frames (``tracking.shaded``): a marker lit from above keeps its shaded
side's weight when the chroma is floored at the frame's own light (real OpenCV, JPEG)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector
from dempath_recon.tracking.shaded import shade_floor

SHAPE = (240, 320)
RADIUS = 4.2  # px: an 8.4 px marker


def frame(seed: int, gain: float) -> tuple[np.ndarray, bytes]:
    """(35, 2) true centres and the JPEG: markers lit from above (their bottom a tenth as
    bright as their middle), the light ``gain`` times the spots' daylight."""
    rng = np.random.default_rng(seed)
    gx, gy = np.meshgrid(np.arange(30, 300, 40), np.arange(30, 220, 40))
    truth = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-5, 5, (gx.size, 2))
    return truth, spot_image(SHAPE, truth, RADIUS, rng, gain=gain, noise_dn=1.0, quality=90,
                             lit_from_up=0.9)


def published_rms(jpeg: bytes, truth: np.ndarray, shade: bool) -> float:
    """RMS distance [px] of each true centre from its nearest published centre."""
    found = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS,
                                          shade_centres=shade)).detect_jpeg(jpeg)
    assert len(found.uv) == len(truth)
    points = found.uv if found.centre is None else found.centre
    err = np.linalg.norm(truth[:, None] - points[None], axis=2).min(axis=1)
    return float(np.sqrt(np.mean(err ** 2)))


def test_dim_frames_publish_centres_on_the_markers_own_light() -> None:
    """Dusk light (sand summing about 60, markers 15-30): the fixed floor divides the shaded
    lower side's chroma down and the centroid lies up the image (RMS about 1 px); on the
    frame's own floor the published centres come within 0.85 px."""
    on, off = [], []
    for seed in (3, 4):
        truth, jpeg = frame(seed, 0.15)
        on.append(published_rms(jpeg, truth, True))
        off.append(published_rms(jpeg, truth, False))
    assert np.mean(off) > 0.95, f'the fixed floor gave {np.mean(off):.2f} px'
    assert np.mean(on) < 0.85 and np.mean(on) < 0.85 * np.mean(off), (on, off)


def test_frames_in_normal_light_are_not_touched() -> None:
    """Sand summing 100 or more keeps the detection's floor: no centre of its own."""
    truth, jpeg = frame(3, 1.0)
    found = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS)).detect_jpeg(jpeg)
    assert found.centre is None and len(found.uv) == len(truth)
    assert shade_floor(60.0, 60.0) is None and shade_floor(35.0, 60.0) == 35.0
