"""The bed floor (``DetectorConfig.exposure_floor='bed'``): at dusk a second search floors the
chroma at a share of the bed's brightness around each pixel and adds the markers it finds to
the frame's own, on a threshold midway between the sand beside the markers and the clay. Real
OpenCV JPEG frames (spots.py), the real detector; each rule is checked against the detector
without it."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spots import SAND, spot_image
from test_colour_model import (
    GREY_SAND,
    RADIUS,
    SHAPE,
    dusk_frame,
    dusk_frame_with_black_corner,
    grid_centres,
    matched,
)

from dempath_recon.tracking import bed_floor as bed_module
from dempath_recon.tracking.bed_floor import BED_SHARE, bed_floor, ring_sand_chroma
from dempath_recon.tracking.colour_model import DARK_SUM_DN, MIN_SUM_DN, SAND_CHROMA, chroma_floor
from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector, decode_jpeg

DEFAULT = DetectorConfig(marker_diameter_px=2 * RADIUS)  # the frame's own floor, 'faint'
BED = DetectorConfig(marker_diameter_px=2 * RADIUS, exposure_floor='bed')


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_dusk_markers_are_found_on_the_bed_floor(seed: int) -> None:
    """Light x0.3 in shadow, markers 30 % buried: the frame's detection finds at most 5 of 35;
    the bed floor 80 % or more within 2.5 px of their visible middles, no spot off a marker,
    and none in bare dark sand."""
    rng = np.random.default_rng(seed)
    truth = grid_centres(rng)
    jpeg = dusk_frame(rng, truth)
    seen = truth - [0.0, 0.3 * RADIUS]
    assert matched(MarkerDetector(DEFAULT).detect_jpeg(jpeg).uv, seen, 2.5)[0] <= 5
    found = MarkerDetector(BED).detect_jpeg(jpeg).uv
    assert matched(found, seen, 2.5)[0] >= 0.8 * len(truth)
    assert matched(found, seen, 4.0)[1] == 0
    bare = dusk_frame(np.random.default_rng(seed + 10), None)
    assert len(MarkerDetector(BED).detect_jpeg(bare).uv) == 0


def test_the_frames_own_spots_are_kept_as_found() -> None:
    """The bed search only adds: the frame's own spots come first, exactly as without it
    (centres, sizes, flags); in normal light nothing is added at all."""
    rng = np.random.default_rng(4)
    truth = grid_centres(rng)
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, gain=0.45, noise_dn=2.0, quality=85,
                      shadow_cols=SHAPE[1] // 2, buried=0.3)
    own, bed = (MarkerDetector(c).detect_jpeg(jpeg) for c in (DEFAULT, BED))
    n = len(own.uv)
    assert 0 < n < len(bed.uv)
    assert np.array_equal(bed.uv[:n], own.uv) and np.array_equal(bed.size_px[:n], own.size_px)
    assert own.parted is not None and bed.parted is not None
    assert np.array_equal(bed.parted[:n], own.parted)
    day = spot_image(SHAPE, truth, RADIUS, rng, sand_bgr=SAND, buried=0.4)
    assert bed_floor(decode_jpeg(day, 2)) is None
    assert np.array_equal(MarkerDetector(BED).detect_jpeg(day).uv,
                          MarkerDetector(DEFAULT).detect_jpeg(day).uv)


def test_the_floor_follows_the_bed_in_light_and_shade() -> None:
    """Dusk with the left half in shade: the bed floor is ``BED_SHARE`` of the sand's own
    brightness on each side (within 20 %), where the frame's one floor (``chroma_floor``)
    lies between them, too high for the shade."""
    rng = np.random.default_rng(6)
    jpeg = spot_image(SHAPE, np.zeros((0, 2)), RADIUS, rng, gain=0.5, noise_dn=2.0,
                      shadow_cols=SHAPE[1] // 2)
    image = decode_jpeg(jpeg, 2)
    beds = bed_floor(image)
    assert beds is not None
    h, w = image.shape[:2]
    total = image.astype(np.float64).sum(axis=2)
    for cols in (slice(4, w // 2 - 8), slice(w // 2 + 8, w - 4)):
        sand = float(np.median(total[4:h - 4, cols]))
        floor = float(np.median(beds.at(4, h - 4, cols.start, cols.stop)))
        assert floor == pytest.approx(min(BED_SHARE * sand, MIN_SUM_DN), rel=0.2), (sand, floor)
    shade = float(np.median(beds.at(4, h - 4, 4, w // 2 - 8)))
    assert chroma_floor(image) > 1.2 * shade


def test_the_sand_beside_the_markers_sets_the_threshold(monkeypatch) -> None:
    """Grey sand at dusk (light x0.3 in shadow, read noise 6 DN) reads near 0 on blue clay's
    chroma, not -0.2: beside the markers the bed reads so (``ring_sand_chroma``), and the bed
    search's threshold midway to the clay leaves at most one spot off the markers in three
    frames; at the fixed threshold (the midpoint rule off) ten or more."""
    import dempath_recon.tracking.detect as detect_module

    def spurious() -> int:
        count = 0
        for seed in range(3):
            rng = np.random.default_rng(seed)
            truth = grid_centres(rng)[::3]
            jpeg = spot_image(SHAPE, truth, RADIUS, rng, gain=0.3, noise_dn=6.0, quality=80,
                              shadow_cols=SHAPE[1], sand_bgr=np.array(GREY_SAND))
            count += matched(MarkerDetector(BED).detect_jpeg(jpeg).uv, truth, 4.0)[1]
        return count

    rng = np.random.default_rng(0)
    truth = grid_centres(rng)[::3]
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, gain=0.3, noise_dn=6.0, quality=80,
                      shadow_cols=SHAPE[1], sand_bgr=np.array(GREY_SAND))
    sand = ring_sand_chroma(decode_jpeg(jpeg, 2), (truth + 0.5) / 2 - 0.5, RADIUS / 2,
                            np.array([1.0, 0.0, -1.0], np.float32))
    assert sand is not None and SAND_CHROMA + 0.1 < sand <= 0.05
    assert spurious() <= 1
    monkeypatch.setattr(detect_module, 'CLAY_CHROMA', -1.0)  # the midpoint never above 0.15
    assert spurious() >= 10, 'the rule is needed: grey sand noise passes without it'


def test_no_spot_in_a_vignetted_corner(monkeypatch) -> None:
    """A dusk frame's near-black lower part (B + G + R about 5, with bluish blotches): the bed
    floor never drops under ``BED_MIN_DN`` there, so no spot in it; floored at
    ``DARK_SUM_DN`` instead, the blotches pass."""
    jpeg, seen = dusk_frame_with_black_corner(3)
    kept = MarkerDetector(BED).detect_jpeg(jpeg).uv
    assert matched(kept, seen, 2.5)[0] >= 12 and not (kept[:, 1] > 150).any()
    monkeypatch.setattr(bed_module, 'BED_MIN_DN', DARK_SUM_DN)
    low = MarkerDetector(BED).detect_jpeg(jpeg).uv
    assert (low[:, 1] > 150).sum() >= 1, 'the rule is needed: blotches pass without it'
