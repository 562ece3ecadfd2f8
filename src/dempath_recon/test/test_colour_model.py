"""The detector's colour model: clay of any colour when set, the sand as the frame shows it, and
a chroma floor that follows the frame's exposure. Real OpenCV JPEG frames (spots.py), the real
detector; each rule is checked against the detector without it."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spots import SAND, spot_image

from dempath_recon.tracking.colour_model import (
    CLAY_CHROMA,
    MIN_SUM_DN,
    REFERENCE_SAND_BGR,
    SAND_CHROMA,
    chroma_floor,
    colour_axis,
    parse_bgr,
)
from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector, decode_jpeg

SHAPE = (240, 320)
RADIUS = 4.2
RED = (0.15, 0.18, 0.62)  # B, G, R albedos
GREEN = (0.22, 0.50, 0.15)
ORANGE = (0.08, 0.35, 0.80)
GREY_SAND = (0.45, 0.45, 0.47)
REDDISH_SAND = (0.25, 0.42, 0.72)


def grid_centres(rng: np.random.Generator) -> np.ndarray:
    """(35, 2) px: markers 40 px apart, jittered."""
    gx, gy = np.meshgrid(np.arange(30, 300, 40), np.arange(30, 220, 40))
    return np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-4, 4, (gx.size, 2))


def matched(found: np.ndarray, truth: np.ndarray, within: float) -> tuple[int, int]:
    """(true markers with a spot within ``within`` px, spots near no marker)."""
    if not len(found):
        return 0, 0
    d = np.linalg.norm(found[:, None] - truth[None], axis=2)
    return int((d.min(axis=0) < within).sum()), int((d.min(axis=1) >= within).sum())


@pytest.mark.parametrize('clay', [RED, GREEN, ORANGE])
def test_clay_of_another_colour_is_found_when_set(clay: tuple[float, float, float]) -> None:
    """Red, green or orange clay on yellow-brown sand: blue clay's chroma finds none; with
    ``marker_bgr`` set every marker is found within 1 px (JPEG keeps chroma at half size) and
    nothing else."""
    rng = np.random.default_rng(7)
    truth = grid_centres(rng)
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, noise_dn=2.0, quality=85,
                      clay_bgr=np.array(clay))
    assert len(MarkerDetector().detect_jpeg(jpeg).uv) == 0
    found = MarkerDetector(DetectorConfig(marker_bgr=clay)).detect_jpeg(jpeg).uv
    assert matched(found, truth, 1.0) == (len(truth), 0)


def test_the_axis_reads_clay_and_sand_as_blue_clay_does() -> None:
    """On its axis a clay reads CLAY_CHROMA and the sand SAND_CHROMA; None is B - R exactly."""
    clay, sand = np.array(RED), np.array(REFERENCE_SAND_BGR)
    axis = colour_axis(RED)
    assert axis @ clay / clay.sum() == pytest.approx(CLAY_CHROMA, abs=1e-6)
    assert axis @ sand / sand.sum() == pytest.approx(SAND_CHROMA, abs=1e-6)
    assert np.array_equal(colour_axis(None), np.array([1.0, 0.0, -1.0], np.float32))


def test_bad_colours_are_refused_by_name() -> None:
    """Not three numbers, out of range, or clay the sand's own colour: one ValueError each."""
    assert parse_bgr('') is None and parse_bgr('blue') is None
    assert parse_bgr('0.15, 0.18, 0.62') == RED
    with pytest.raises(ValueError, match=r'marker_bgr.*three numbers'):
        parse_bgr('red')
    with pytest.raises(ValueError, match=r'marker_bgr.*albedos in'):
        parse_bgr('0.1,0.2,1.5')
    with pytest.raises(ValueError, match='cannot be told from sand'):
        DetectorConfig(marker_bgr=(0.43, 0.59, 0.70))


@pytest.mark.parametrize(('clay', 'sand'), [(RED, GREY_SAND), (ORANGE, GREY_SAND)])
def test_the_frames_own_sand_sets_the_axis(clay: tuple[float, float, float],
                                           sand: tuple[float, float, float]) -> None:
    """Half-buried red or orange markers on grey sand (light x0.5, noise 3): the axis from the
    frame's sand finds most; the axis from the yellow reference sand puts the grey sand near
    the threshold's other side and finds few."""
    rng = np.random.default_rng(7)
    truth = grid_centres(rng)
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, gain=0.5, noise_dn=3.0, quality=80,
                      sand_bgr=np.array(sand), clay_bgr=np.array(clay), buried=0.5)
    seen = truth - [0.0, 0.4 * RADIUS]  # the middle of the visible half
    own = MarkerDetector(DetectorConfig(marker_bgr=clay)).detect_jpeg(jpeg).uv
    fixed = MarkerDetector(DetectorConfig(marker_bgr=clay, sand_bgr=REFERENCE_SAND_BGR)
                           ).detect_jpeg(jpeg).uv
    found, spurious = matched(own, seen, 3.0)
    assert found >= 15 and spurious == 0, (found, spurious)
    assert matched(fixed, seen, 3.0)[0] <= 5


def test_reddish_sand_gives_no_spots_on_the_frames_axis() -> None:
    """Red clay on reddish sand: the reference sand's axis reads the sand's redder grains as
    clay (spots everywhere, under the fixed rule: the band-pass measures them against the sand
    around them); the frame's own sand gives the markers and nothing else."""
    rng = np.random.default_rng(7)
    truth = grid_centres(rng)
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, gain=0.5, noise_dn=3.0, quality=80,
                      sand_bgr=np.array(REDDISH_SAND), clay_bgr=np.array(RED), buried=0.5)
    seen = truth - [0.0, 0.4 * RADIUS]
    own = MarkerDetector(DetectorConfig(marker_bgr=RED)).detect_jpeg(jpeg).uv
    fixed = MarkerDetector(DetectorConfig(marker_bgr=RED, sand_bgr=REFERENCE_SAND_BGR,
                                          band_pass=False)).detect_jpeg(jpeg).uv
    assert matched(own, seen, 3.0) == (len(truth), 0)
    assert matched(fixed, seen, 3.0)[1] >= 10


def dusk_frame(rng: np.random.Generator, truth: np.ndarray | None) -> bytes:
    """JPEG at light x0.3 in shadow (sand B + G + R about 40, as the twin's dusk looks),
    markers 30 % buried, or bare sand (``truth`` None)."""
    centres = np.zeros((0, 2)) if truth is None else truth
    return spot_image(SHAPE, centres, RADIUS, rng, gain=0.3, noise_dn=2.0, quality=85,
                      shadow_cols=SHAPE[1], buried=0.3)


def test_frames_in_normal_light_keep_the_fixed_floor() -> None:
    """Sand in normal light sums to 100 or more: the floor stays MIN_SUM_DN, and the detections
    and the faint search beside predictions are those of the fixed floor."""
    rng = np.random.default_rng(9)
    truth = grid_centres(rng)
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, sand_bgr=SAND, buried=0.4)
    assert chroma_floor(decode_jpeg(jpeg, 2)) == MIN_SUM_DN
    own = MarkerDetector(DetectorConfig()).detect_jpeg(jpeg)
    fixed = MarkerDetector(DetectorConfig(exposure_floor='off')).detect_jpeg(jpeg)
    assert np.array_equal(own.uv, fixed.uv) and len(own.uv) >= 0.5 * len(truth)
    pred = truth + np.random.default_rng(2).normal(0, 1.0, truth.shape)
    assert own.faint is not None and fixed.faint is not None
    np.testing.assert_array_equal(own.faint(pred, 4.0), fixed.faint(pred, 4.0))


def dusk_frame_with_black_corner(seed: int) -> tuple[bytes, np.ndarray]:
    """JPEG of 15 markers at dusk (as ``dusk_frame``) whose lower part is near black (B + G + R
    about 5, a vignetted corner or the tool's shadow) with faint bluish blotches (B + 7 DN over
    3 px, as the twin's JPEG leaves in its black corners), and the markers' (15, 2) visible
    middles [px]."""
    import cv2

    rng = np.random.default_rng(seed)
    truth = grid_centres(rng)[:15]
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, gain=0.3, noise_dn=2.0, quality=85,
                      shadow_cols=SHAPE[1], buried=0.3)
    img = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR).astype(np.float64)
    img[140:] = img[140:] * 0.06 + 1
    yy, xx = np.mgrid[0:SHAPE[0], 0:SHAPE[1]]
    for bx, by in np.column_stack([np.arange(20, 320, 40), np.full(8, 190)]):
        img[..., 0] += 7.0 * np.exp(-((xx - bx) ** 2 + (yy - by) ** 2) / (2 * 3.0 ** 2))
    ok, out = cv2.imencode('.jpg', np.clip(np.round(img), 0, 255).astype(np.uint8),
                           [cv2.IMWRITE_JPEG_QUALITY, 85])
    assert ok
    return out.tobytes(), truth - [0.0, 0.3 * RADIUS]


def test_the_faint_search_uses_the_frames_floor_by_default() -> None:
    """By default ('faint') the frame's own detections keep the fixed floor (none of the dark
    markers), and the faint search beside predictions finds them within 2.5 px on the frame's
    floor (most), where with the fixed floor (and no local bar) it finds about half; none in
    bare sand."""
    rng = np.random.default_rng(5)
    truth = grid_centres(rng)
    jpeg = dusk_frame(rng, truth)
    seen = truth - [0.0, 0.3 * RADIUS]
    pred = seen + np.random.default_rng(1).normal(0, 1.0, seen.shape)
    own = MarkerDetector(DetectorConfig(local_bar=False)).detect_jpeg(jpeg)
    fixed = MarkerDetector(DetectorConfig(local_bar=False, exposure_floor='off')
                           ).detect_jpeg(jpeg)
    assert matched(own.uv, seen, 2.5)[0] <= 5
    assert own.faint is not None and fixed.faint is not None
    near = np.linalg.norm(own.faint(pred, 4.0) - seen, axis=1) < 2.5
    assert near.mean() >= 0.8, f'{near.mean():.0%} found beside predictions'
    assert (np.linalg.norm(fixed.faint(pred, 4.0) - seen, axis=1) < 2.5).mean() <= 0.5
    assert not np.isfinite(own.faint(seen + np.array([20.0, 0.0]), 4.0)).all(axis=1).any()


def test_a_dim_frames_markers_are_found_on_its_own_light() -> None:
    """At dusk the fixed floor divides half-buried markers under the threshold; the dim pass
    (``dim_spots``) finds them on the frame's own floor beside the whole markers
    it found, keeps the fixed floor's spots as they were, and adds none off the markers."""
    rng = np.random.default_rng(11)
    truth = grid_centres(rng)
    buried = np.where(np.arange(len(truth)) % 3 == 0, 0.0, 0.3)  # a third whole
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, gain=0.3, noise_dn=2.0, quality=85,
                      shadow_cols=SHAPE[1], buried=buried)
    seen = truth - np.column_stack([np.zeros(len(truth)), buried * RADIUS])
    config = DetectorConfig(marker_diameter_px=2 * RADIUS, dim_spots=True)
    dim = MarkerDetector(config).detect_jpeg(jpeg)
    fixed = MarkerDetector(replace(config, dim_spots=False)).detect_jpeg(jpeg)
    half = buried > 0
    found_fixed = matched(fixed.uv, seen[half], 2.5)[0]
    found_dim = matched(dim.uv, seen[half], 2.5)[0]
    assert found_fixed <= 0.25 * half.sum(), f'{found_fixed} of {half.sum()} at the fixed floor'
    assert found_dim >= 0.75 * half.sum(), f'{found_dim} of {half.sum()} with the dim pass'
    assert matched(dim.uv, seen, 3.0)[1] == 0
    np.testing.assert_array_equal(dim.uv[:len(fixed.uv)], fixed.uv)
    assert dim.crowded is not None and dim.parted is not None and dim.centre is not None
    assert len(dim.crowded) == len(dim.parted) == len(dim.centre) == len(dim.uv)


RED_ON_SLATE = (0.30, 0.42, 0.78)  # red clay the twin renders on slate sand
SLATE = np.array([0.42, 0.44, 0.47])


def red_clay_with_dark_corners(seed: int) -> tuple[bytes, np.ndarray]:
    """JPEG of red clay on slate sand in normal light whose bottom rows and right columns,
    beyond the markers, are near black (B + G + R about 6-25, a vignetted view's corners) with
    faint warm blotches (R + 8 DN over 3 px, as the twin's JPEG leaves there), and the
    markers' (35, 2) px centres."""
    import cv2

    rng = np.random.default_rng(seed)
    truth = grid_centres(rng)
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, noise_dn=2.0, quality=85, sand_bgr=SLATE,
                      clay_bgr=np.array(RED_ON_SLATE))
    img = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR).astype(np.float64)
    dark = np.zeros(SHAPE, bool)
    dark[205:] = True
    dark[:, 287:] = True
    img[dark] = img[dark] * 0.06 + 1
    yy, xx = np.mgrid[0:SHAPE[0], 0:SHAPE[1]]
    blotches = [*((x, 222) for x in range(20, 280, 30)), *((303, y) for y in range(20, 200, 30))]
    for bx, by in blotches:
        img[..., 2] += 8.0 * np.exp(-((xx - bx) ** 2 + (yy - by) ** 2) / (2 * 3.0 ** 2))
    ok, out = cv2.imencode('.jpg', np.clip(np.round(img), 0, 255).astype(np.uint8),
                           [cv2.IMWRITE_JPEG_QUALITY, 85])
    assert ok
    return out.tobytes(), truth


def test_another_clays_spots_in_near_black_corners_are_dropped(monkeypatch) -> None:
    """Red clay on slate sand: the near-black corners' warm JPEG tint passes the red clay's
    axis (its weights 2-3 times blue's) as spots; ``clay_bar`` keeps only spots at least half
    the frame's median brightness: every marker in the lit part, no spot in the dark part. Blue
    clay's axis has no such bar."""
    import dempath_recon.tracking.colour_model as colour_module

    jpeg, lit = red_clay_with_dark_corners(11)
    config = DetectorConfig(marker_bgr=RED_ON_SLATE)
    kept = MarkerDetector(config).detect_jpeg(jpeg).uv
    assert matched(kept, lit, 1.5) == (len(lit), 0), matched(kept, lit, 1.5)
    monkeypatch.setattr(colour_module, 'CLAY_DARK_SHARE', 0.0)
    ungated = MarkerDetector(config).detect_jpeg(jpeg).uv
    assert matched(ungated, lit, 1.5)[1] >= 2, 'the bar is needed: the tint passes without it'
    assert colour_module.clay_bar(decode_jpeg(jpeg, 2), colour_module.colour_axis(None)) == 0.0
