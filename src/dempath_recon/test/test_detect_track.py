"""Marker detection, tracking and two-camera numbering against rendered known truth."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath_recon.tracking.associate import MarkerGrid, epipolar_distance, number_by_grid
from dempath_recon.tracking.colour_model import ChromaParts
from dempath_recon.tracking.detect import (
    Detections,
    DetectorConfig,
    ImageDecodeError,
    MarkerDetector,
    decode_jpeg,
)
from dempath_recon.tracking.linker import MarkerTracker, track_sequence
from dempath_recon.tracking.stereo import StereoMarkerTracker, triangulate_tracks

SHAPE = (240, 320)


def grid_centres(rng: np.random.Generator) -> np.ndarray:
    """35 well separated centres (px) with random sub-pixel offsets."""
    gx, gy = np.meshgrid(np.arange(30, 300, 40), np.arange(30, 220, 40))
    return np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-5, 5, (gx.size, 2))


def errors(det: Detections, truth: np.ndarray) -> np.ndarray:
    """(n, 2) detection minus truth for the nearest detection of each true centre."""
    d = np.linalg.norm(det.uv[None] - truth[:, None], axis=2)
    return det.uv[d.argmin(axis=1)] - truth


@pytest.mark.parametrize(('downscale', 'tolerance'), [(1, 0.12), (2, 0.2)])
def test_subpixel_centres_on_clean_spots(downscale: int, tolerance: float) -> None:
    """Spots of 4.5 px radius, JPEG 95: centres within 0.12 px RMS (0.2 at half size)."""
    rng = np.random.default_rng(1)
    det = MarkerDetector(DetectorConfig(downscale=downscale))
    errs = []
    for _ in range(3):
        truth = grid_centres(rng)
        found = det.detect_jpeg(spot_image(SHAPE, truth, 4.5, rng, quality=95))
        assert len(found.uv) == len(truth)
        errs.append(errors(found, truth))
    e = np.concatenate(errs)
    assert np.sqrt((e ** 2).sum(axis=1).mean()) < tolerance
    assert np.abs(e.mean(axis=0)).max() < 0.05  # no bias


def test_sand_texture_shadow_and_gain_do_not_matter() -> None:
    """No detection in bare sand; markers in a deep shadow and at low gain are all found."""
    rng = np.random.default_rng(2)
    det = MarkerDetector()
    assert len(det.detect_jpeg(spot_image(SHAPE, np.zeros((0, 2)), 4.0, rng)).uv) == 0
    truth = grid_centres(rng)
    found = det.detect_jpeg(spot_image(SHAPE, truth, 4.0, rng, gain=0.6, shadow_cols=160))
    assert len(found.uv) == len(truth)
    e = errors(found, truth)  # light down to 21 %: 30 grey levels of blue on 1.5 of noise
    assert np.sqrt((e ** 2).sum(axis=1).mean()) < 0.4 and np.abs(e).max() < 1.0


def test_corrupt_jpeg_raises_decode_error() -> None:
    """Truncated and empty JPEG data give ImageDecodeError, not a crash."""
    good = spot_image(SHAPE, np.zeros((0, 2)), 4.0, np.random.default_rng(0))
    with pytest.raises(ImageDecodeError):
        decode_jpeg(b'\xff\xd8garbage')
    with pytest.raises(ImageDecodeError):
        decode_jpeg(b'')
    assert decode_jpeg(good).shape == (*SHAPE, 3)


def test_truncated_jpeg_is_an_error_and_half_size_matches_opencv() -> None:
    """A JPEG cut short is refused (not decoded to a half-grey frame); the half-size decode is
    OpenCV's reduced decode pixel for pixel (the same DCT scaling: half-size pixel i is
    full-size 2i + 0.5, which the detector's centres rely on)."""
    import cv2

    good = spot_image(SHAPE, grid_centres(np.random.default_rng(3)), 4.0,
                      np.random.default_rng(3))
    with pytest.raises(ImageDecodeError):
        decode_jpeg(good[:len(good) // 2], 2)
    half = decode_jpeg(good, 2)
    ref = cv2.imdecode(np.frombuffer(good, np.uint8), cv2.IMREAD_REDUCED_COLOR_2)
    assert half.shape == (SHAPE[0] // 2, SHAPE[1] // 2, 3)
    assert np.array_equal(half, ref)


RED_CLAY = np.array([0.15, 0.18, 0.62])  # B, G, R albedo


class WholeFrameDetector(MarkerDetector):
    """The detector with its chroma computed over the whole frame (the reference)."""

    def _window(self, image: np.ndarray, thr: float, floor: float = 60.0,
                axis: np.ndarray | None = None) -> tuple[int, int, np.ndarray, ChromaParts]:
        from dempath_recon.tracking.detect import chroma_parts

        parts = chroma_parts(image, axis)
        return 0, 0, parts.floored(floor), parts


@pytest.mark.parametrize('corner', [(600, 400), (8, 6), (1890, 1070)])
def test_window_around_candidates_gives_the_whole_frame_result(corner: tuple[int, int]) -> None:
    """Markers in a small part of a 1920x1080 frame (mid-frame, and against two corners, where
    the window is clipped), blue or red clay (its axis), in daylight or at dusk (the frame's
    lowered chroma floor, the window only near lit pixels), with the band-pass or without: the
    detections equal those of the chroma of the whole frame."""
    rng = np.random.default_rng(4)
    offsets = np.array([[0, 0], [25, 3], [-30, 12], [12, -28], [60, 40], [-55, -40]], float)
    centres = np.clip(np.asarray(corner, float) + offsets + rng.uniform(-0.5, 0.5, (6, 2)),
                      [4, 4], [1915, 1075])
    frames = {'blue': spot_image((1080, 1920), centres, 4.5, rng, quality=90),
              'red': spot_image((1080, 1920), centres, 4.5, rng, quality=90, clay_bgr=RED_CLAY),
              'dusk': spot_image((1080, 1920), centres, 4.5, rng, gain=0.3, noise_dn=2.0,
                                 quality=85, shadow_cols=1920)}
    for downscale, look, band in ((1, 'blue', False), (2, 'blue', False), (2, 'red', False),
                                  (1, 'red', False), (2, 'dusk', False), (1, 'dusk', False),
                                  (2, 'blue', True), (2, 'dusk', True)):
        config = DetectorConfig(downscale=downscale,
                                marker_bgr=tuple(RED_CLAY) if look == 'red' else None,
                                band_pass=band, marker_diameter_px=9.0 if band else 0.0)
        jpeg = frames[look]
        found = MarkerDetector(config).detect_jpeg(jpeg)
        ref = WholeFrameDetector(config).detect_jpeg(jpeg)
        # the markers the frame shows (some cut by the border; at dusk dark clay at a corner)
        assert len(ref.uv) >= (2 if look == 'dusk' else 4)
        assert np.allclose(found.uv, ref.uv, atol=1e-9)
        assert np.allclose(found.confidence, ref.confidence)


def test_stray_bluish_pixels_across_the_view_do_not_widen_the_window() -> None:
    """A bright, slightly bluish speck in each corner (its ``B - R`` above the byte bound but its
    chroma 0.06, under the threshold: a grey bed's glints) beside markers mid-frame: the window
    is narrowed to the markers (under a tenth of the frame, where the byte bound's box is the
    whole frame) and the detections equal those of the whole frame's chroma."""
    rng = np.random.default_rng(8)
    centres = np.array([[900.0, 500.0], [930.0, 520.0], [880.0, 540.0]]) + rng.uniform(0, 1, 2)
    image = cv2.imdecode(np.frombuffer(spot_image((1080, 1920), centres, 4.5, rng, quality=95),
                                       np.uint8), cv2.IMREAD_COLOR)
    for x, y in ((3, 3), (1915, 4), (5, 1075), (1914, 1074)):
        image[y - 1:y + 2, x - 1:x + 2] = (130, 110, 110)  # B - R = 20 DN, chroma 0.06
    config = DetectorConfig(downscale=1)
    detector = MarkerDetector(config)
    _, _, window, _ = detector._window(image, config.threshold)
    assert 0 < window.size < 0.1 * 1080 * 1920
    found, ref = detector.detect(image), WholeFrameDetector(config).detect(image)
    assert len(found.uv) == 3 and np.allclose(found.uv, ref.uv, atol=1e-9)


def moving(n_frames: int, rng: np.random.Generator) -> np.ndarray:
    """(n_frames, 6, 2) px: six markers moving with different constant velocities."""
    start = rng.uniform([40, 40], [280, 200], (6, 2))
    start[:, 0] = np.linspace(40, 280, 6)
    vel = rng.uniform(-6, 6, (6, 2))
    return start[None] + vel[None] * np.arange(n_frames)[:, None, None]


def dets(uv: np.ndarray) -> Detections:
    """Detections at exact positions (tracking tests)."""
    return Detections(uv, np.ones(len(uv)), np.full(len(uv), 3.0))


def test_tracker_links_identities_and_reattaches_covered_marker() -> None:
    """Six markers over 12 frames: ids stay; marker 2 covered 3 frames, re-attached, said so."""
    uv = moving(12, np.random.default_rng(3))
    tracker = MarkerTracker()
    tracker.seed(uv[0], np.arange(1, 7, dtype=np.int32), -0.02)
    events = []
    for k in range(12):
        keep = np.ones(6, bool)
        if 4 <= k < 7:
            keep[1] = False  # covered by sand
        frame = tracker.update(k * 0.02, dets(uv[k][keep][::-1]))  # order does not matter
        events += frame.events
        for m, p in zip(frame.markers, frame.uv, strict=True):
            assert np.allclose(p, uv[k][m - 1]), (k, m)
    assert any('lost track 1 (marker 2)' in e for e in events)
    assert any('re-attached track 1 (marker 2)' in e for e in events)
    assert tracker.counts.lost == 1 and tracker.counts.reattached == 1


def test_tracker_never_joins_a_far_detection_to_a_lost_track() -> None:
    """A marker covered for good and another appearing far away: a new, unnumbered track."""
    tracker = MarkerTracker()
    tracker.seed(np.array([[50.0, 50.0]]), np.array([7], np.int32), -0.02)
    tracker.update(0.0, dets(np.array([[50.0, 50.0]])))
    tracker.update(0.02, dets(np.zeros((0, 2))))
    frame = tracker.update(0.04, dets(np.array([[200.0, 150.0]])))
    assert list(frame.markers) == [-1]
    assert any('new track' in e for e in frame.events)


def test_streaming_and_batch_agree() -> None:
    """track_sequence gives exactly the frames of update() called one at a time."""
    uv = moving(10, np.random.default_rng(4))
    frames = [(k * 0.02, dets(uv[k])) for k in range(10)]
    seed = (uv[0], np.arange(1, 7, dtype=np.int32), -0.02)
    batch, _ = track_sequence(frames, seed=seed)
    tracker = MarkerTracker()
    tracker.seed(*seed)
    for (t, d), b in zip(frames, batch, strict=True):
        s = tracker.update(t, d)
        assert np.array_equal(s.markers, b.markers) and np.array_equal(s.uv, b.uv)


def test_grid_numbering_with_unknown_height(rig) -> None:
    """Grid points raised by 30 mm and jittered by 3 mm still get their numbers."""
    grid = MarkerGrid()
    numbers, xyz = grid.points()
    rng = np.random.default_rng(5)
    real = xyz + np.array([0.0, 0.03, 0.0]) + rng.normal(0, 0.003, xyz.shape)
    for cam in rig.cameras:
        order = rng.permutation(len(real))
        got, _ = number_by_grid(cam, cam.project(real[order]), grid)
        assert np.array_equal(got, numbers[order])


def test_grid_fit_that_a_pitch_over_fits_as_well_is_refused(rig) -> None:
    """The 3 x 5 grid with its last column hidden: the fit one column over scores as well, so
    a wary fit numbers nothing (the numbering waits for a frame that tells them apart); with
    every column in view the wary fit numbers them all."""
    grid = MarkerGrid()
    numbers, xyz = grid.points()
    inner = (numbers - 1) % grid.columns < grid.columns - 1
    for cam in rig.cameras:
        got, _ = number_by_grid(cam, cam.project(xyz[inner]), grid, wary=True)
        assert (got == -1).all(), f'{cam.name}: {got}'
        got, _ = number_by_grid(cam, cam.project(xyz), grid, wary=True)
        assert np.array_equal(got, numbers)


def test_epipolar_distance_is_zero_for_true_pairs(rig) -> None:
    """Projections of one point lie on each other's epipolar lines; others do not."""
    pts = np.array([[0.0, 0.02, 0.0], [0.1, 0.0, -0.1]])
    side, front = rig.cameras
    d = epipolar_distance(side, front, side.project(pts), front.project(pts))
    assert d[0, 0] < 1e-6 and d[1, 1] < 1e-6 and d[0, 1] > 5


def half_size(cam):
    """The camera with a 960 x 540 sensor (fast tests)."""
    k = cam.K.copy()
    k[:2] *= 0.5
    k[:2, 2] = (cam.K[:2, 2] + 0.5) * 0.5 - 0.5
    return replace(cam, width=cam.width // 2, height=cam.height // 2, K=k)


def stereo_jpegs(cams, xyz: np.ndarray, rng: np.random.Generator) -> list[bytes]:
    """JPEGs of markers at xyz (m, 3) in both cameras (side, front)."""
    return [spot_image((c.height, c.width), c.project(xyz), 3.0, rng, quality=92) for c in cams]


@pytest.mark.parametrize('drop_side', [False, True])
def test_stereo_pipeline_numbers_and_triangulates(rig, drop_side: bool) -> None:
    """Grid markers in both cameras: numbered, tracked, 3D within 1 mm RMS; faults counted."""
    grid = MarkerGrid()
    numbers, xyz0 = grid.points()
    rng = np.random.default_rng(6)
    cams = {c.name: half_size(c) for c in rig.cameras}
    tracker = StereoMarkerTracker(cams)
    frames, truth = [], []
    for k in range(6):
        xyz = xyz0 + np.array([0.0, 0.01, 0.004 * k])
        truth.append(xyz)
        side, front = stereo_jpegs(list(cams.values()), xyz, rng)
        if k == 3:
            side = side[:200]  # corrupt JPEG
        if not (drop_side and k == 4):
            frames.append(tracker.update('cam_side', 0.02 * k, side))
        frames.append(tracker.update('cam_front', 0.02 * k + 1e-4, front))
    rep = tracker.report()
    assert rep['cam_side']['undecodable'] == 1
    assert rep['cam_side']['dropped'] == (2 if drop_side else 1)
    assert rep['cam_front']['lost'] == 0
    times, markers, got = triangulate_tracks(frames, cams, 'cam_side')
    assert list(markers) == list(numbers)
    ok = np.isfinite(got).all(axis=2).all(axis=1)
    k_ok = np.round(times[ok] / 0.02).astype(int)
    err = np.linalg.norm(got[ok] - np.array(truth)[k_ok], axis=2)
    assert np.sqrt((err ** 2).mean()) < 1e-3 and err.max() < 2e-3, err.max()  # half-size images
