"""Streaked and dark markers beside a track's prediction (real OpenCV, JPEG; tracking.streak)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath_recon.tracking import detect
from dempath_recon.tracking.detect import Detections, DetectorConfig, MarkerDetector
from dempath_recon.tracking.linker import MarkerTracker, TrackerConfig

SHAPE = (240, 320)
FPS = 50.0


def grid_centres(rng: np.random.Generator) -> np.ndarray:
    """(24, 2) centres [px] 50 px apart with random sub-pixel offsets."""
    gx, gy = np.meshgrid(np.arange(40, 300, 50), np.arange(40, 220, 50))
    return np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-3, 3, (gx.size, 2))


def test_streaked_markers_are_found_along_their_motion_only() -> None:
    """Markers smeared 20 px (a 12 ms shutter at light x0.3) are neither detections nor faint
    spots (the fixed bar); the search along their motion finds each within 1.6 px of its
    centre (0.9 px on average), and nothing on bare sand beside them."""
    rng = np.random.default_rng(4)
    truth = grid_centres(rng)
    step = np.array([16.0, 12.0])  # 20 px during the exposure
    jpeg = spot_image(SHAPE, truth, 4.5, rng, gain=0.3, noise_dn=3.0, quality=85,
                      streak=(float(step[0]), float(step[1])))
    det = MarkerDetector(DetectorConfig(local_bar=False)).detect_jpeg(jpeg)
    assert det.faint is not None
    assert len(det.uv) == 0, f'{len(det.uv)} streaks passed the fixed threshold'
    pred = truth + rng.normal(0, 1.5, truth.shape)
    steps = np.tile(step, (len(truth), 1))
    spots = det.faint(pred, 4.0)
    assert not np.isfinite(spots).all(axis=1).any(), 'the round faint search found a streak'
    found = det.faint(pred, 4.0, steps)
    err = np.linalg.norm(found - truth, axis=1)
    assert np.all(err < 1.6) and err.mean() < 0.9, \
        f'streak centres off by {np.nanmax(err):.2f} px (mean {np.nanmean(err):.2f})'
    bare = det.faint(truth + np.array([25.0, 0.0]), 4.0, steps)
    assert not np.isfinite(bare).all(axis=1).any(), 'a streak found in bare sand'


def streak_frames(rng: np.random.Generator, exposure_s: float,
                  ) -> tuple[list[bytes], np.ndarray]:
    """JPEGs of three markers speeding up from 800 to 1500 px/s along u at ``FPS`` (their
    smear: speed x exposure), and their (frames, 3, 2) centres [px] at each frame's middle of
    exposure."""
    speeds = np.linspace(800.0, 1500.0, 8)
    start = np.array([[30.0, 60.0], [30.0, 120.0], [30.0, 180.0]])
    u = np.concatenate([[0.0], np.cumsum(speeds[1:] / FPS)])
    centres = np.stack([start + np.array([du, 0.0]) for du in u])
    images = [spot_image(SHAPE, c, 4.5, rng, gain=0.3, noise_dn=3.0, quality=85,
                         streak=(float(v * exposure_s), 0.0))
              for c, v in zip(centres, speeds, strict=True)]
    return images, centres


def run_tracker(images: list[bytes], exposure_s: float,
                local_bar: bool = True) -> list[tuple[int, np.ndarray]]:
    """Each frame's (numbered tracks seen, their (k, 2) positions [px]), numbered from the
    first frame's detections."""
    detector = MarkerDetector(DetectorConfig(local_bar=local_bar))
    tracker = MarkerTracker(TrackerConfig(exposure_s=exposure_s))
    out = []
    for k, jpeg in enumerate(images):
        det: Detections = detector.detect_jpeg(jpeg)
        frame = tracker.update(k / FPS, det)
        if k == 0:
            for tid, m in zip(frame.track_ids, range(len(frame.track_ids)), strict=True):
                tracker.number(int(tid), m)
        seen = frame.markers >= 0 if k else np.ones(len(frame.markers), bool)
        out.append((int(seen.sum()), frame.uv[np.argsort(frame.uv[:, 1])]))
    return out


def test_a_track_keeps_its_speeding_marker_through_its_streaks() -> None:
    """Markers speeding up under a 12 ms shutter smear past what the detector finds (14-18 px);
    the tracks told the exposure follow them along their streaks within 1.1 px (the detector's
    own centres of 10-12 px streaks: within 2 px), every frame; not told it (the round faint
    search with the fixed bar), they lose them."""
    rng = np.random.default_rng(7)
    images, centres = streak_frames(rng, 0.012)
    detector = MarkerDetector()
    missing = [len(detector.detect_jpeg(j).uv) < 3 for j in images]
    assert sum(missing) >= 3, 'the streaks were all found without the streak search'
    told = run_tracker(images, 0.012)
    for k, (seen, uv) in enumerate(told):
        assert seen == 3, f'frame {k}: {seen} of 3 markers followed'
        err = np.linalg.norm(uv - centres[k], axis=1).max()
        assert err < (1.1 if missing[k] else 2.0), f'frame {k}: {err:.2f} px off'
    blind = run_tracker(images, 0.0, local_bar=False)
    assert min(seen for seen, _ in blind) < 3, 'the markers were followed without the exposure'


def dark_buried_markers(rng: np.random.Generator) -> tuple[bytes, np.ndarray]:
    """JPEG of 35 markers 30 % buried in deep shadow at light x0.2 (B + G + R of the sand about
    25 grey levels), and the (35, 2) middles of their visible parts [px]."""
    gx, gy = np.meshgrid(np.arange(30, 300, 40), np.arange(30, 220, 40))
    truth = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-4, 4, (gx.size, 2))
    jpeg = spot_image(SHAPE, truth, 4.2, rng, gain=0.2, noise_dn=2.0, quality=85,
                      shadow_cols=SHAPE[1], buried=0.3)
    return jpeg, truth - [0.0, 4.2 * 0.3]


def test_dark_markers_are_found_beside_a_prediction_by_the_windows_noise() -> None:
    """In deep shadow at dusk a marker keeps its colour but not the brightness the frame-wide
    chroma floor assumes: the detector with the fixed floor finds none (the frame's own floor,
    ``exposure_floor``, is tested in test_colour_model); beside a prediction the search with
    the window's own noise bar finds most (within 2 px), and none in bare dark sand."""
    rng = np.random.default_rng(5)
    jpeg, visible = dark_buried_markers(rng)
    det = MarkerDetector(DetectorConfig(exposure_floor='off')).detect_jpeg(jpeg)
    assert det.faint is not None and len(det.uv) == 0
    pred = visible + rng.normal(0, 1.0, visible.shape)
    err = np.linalg.norm(det.faint(pred, 4.0) - visible, axis=1)
    assert np.mean(err < 2.0) > 0.7, f'found {np.mean(err < 2.0):.0%} of the dark markers'
    bare = det.faint(visible + np.array([20.0, 0.0]), 4.0)
    assert not np.isfinite(bare).all(axis=1).any(), 'a spot found in bare dark sand'


def test_without_the_local_bar_dark_markers_stay_lost() -> None:
    """The rule matters: with the fixed bar only, the faint search finds few of them."""
    rng = np.random.default_rng(5)
    jpeg, visible = dark_buried_markers(rng)
    det = MarkerDetector(DetectorConfig(local_bar=False, exposure_floor='off')).detect_jpeg(jpeg)
    assert det.faint is not None
    pred = visible + rng.normal(0, 1.0, visible.shape)
    err = np.linalg.norm(det.faint(pred, 4.0) - visible, axis=1)
    assert np.mean(err < 2.0) < 0.2, f'found {np.mean(err < 2.0):.0%} without the local bar'


def test_in_bright_sand_a_sunk_markers_cap_stays_unfound(monkeypatch: pytest.MonkeyPatch) -> None:
    """The local bar only where the sand is dim: in daylight a marker 70 % buried (a cap under
    half its disc, whose centre lies off the sphere's) is not taken beside a prediction (at
    most 3 of 35 by the fixed faint bar); the same search in bright windows (the gate off)
    takes most of them, which on the tuning looks raised switches."""
    rng = np.random.default_rng(5)
    gx, gy = np.meshgrid(np.arange(30, 300, 40), np.arange(30, 220, 40))
    truth = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-4, 4, (gx.size, 2))
    jpeg = spot_image(SHAPE, truth, 4.2, rng, gain=1.0, noise_dn=2.0, quality=85, buried=0.7)
    cap = truth - np.array([0.0, 4.2 * 0.7])
    det = MarkerDetector().detect_jpeg(jpeg)
    assert det.faint is not None and len(det.uv) == 0
    assert np.isfinite(det.faint(cap, 4.0)).all(axis=1).sum() <= 3
    monkeypatch.setattr(detect, 'dim', lambda image, below=0.0: True)
    ungated = MarkerDetector().detect_jpeg(jpeg)
    assert ungated.faint is not None
    assert np.isfinite(ungated.faint(cap, 4.0)).all(axis=1).sum() > 20
