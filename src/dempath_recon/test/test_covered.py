"""Partly covered markers' centres (``tracking.covered``): the disc's centre is published, not
the middle of the visible part (real OpenCV, JPEG)."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath_recon.tracking.covered import MAX_ELEVATION_DEG, segment_offset
from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector
from dempath_recon.tracking.stereo import published_centres

SHAPE = (240, 320)
RADIUS = 4.2  # px: an 8.4 px marker
UP = (0.0, -1.0)  # the spots' sand hides each marker's lower part


def frame(seed: int, buried: float) -> tuple[np.ndarray, np.ndarray, bytes]:
    """(35, 2) true centres, (35,) which are covered (every third, ``buried`` of its height
    under the sand), and the JPEG."""
    rng = np.random.default_rng(seed)
    gx, gy = np.meshgrid(np.arange(30, 300, 40), np.arange(30, 220, 40))
    truth = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-5, 5, (gx.size, 2))
    covered = np.arange(len(truth)) % 3 == 0
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, buried=np.where(covered, buried, 0.0),
                      noise_dn=2.0, quality=85)
    return truth, covered, jpeg


def miss(points: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(n,) each true centre's distance to the nearest point [px]."""
    return np.asarray(np.linalg.norm(truth[:, None] - points[None], axis=2).min(axis=1))


def test_segment_offset_is_the_segments_centroid() -> None:
    """Side-on, a whole disc's centroid is its centre, a half disc's lies 4 / (3 pi) radii from
    it, and the less is seen the farther it lies; seen from higher up the seen part lies
    nearer the centre (from straight above a sunk sphere shows a disc about its centre)."""
    share = np.array([1.0, 0.75, 0.5, 0.25])
    got = segment_offset(share)
    assert got[0] == pytest.approx(0.0, abs=1e-9)
    assert got[2] == pytest.approx(4.0 / (3.0 * np.pi), abs=2e-3)
    assert np.all(np.diff(got) > 0)
    high = segment_offset(share, 60.0)
    assert np.all(high[1:] < got[1:]) and np.all(high[1:] > 0)
    assert high[2] < got[2] - 0.05  # a half seen from 60 degrees: 0.33 radii, not 0.42
    assert np.allclose(segment_offset(share, 90.0), 0.0, atol=1e-4)


@pytest.mark.parametrize('buried', [0.45, 0.55])
def test_partly_covered_markers_publish_their_disc_centre(buried: float) -> None:
    """Markers 40-56 % visible (45-55 % of their height under the sand) among whole ones: the
    centroid lies 1.6-2.1 px up from the centre; the published centre within 0.7 px on
    average, and the whole markers' centres stay within 0.35 px."""
    det = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS, up_px=UP))
    for seed in (3, 4):
        truth, covered, jpeg = frame(seed, buried)
        found = det.detect_jpeg(jpeg)
        assert len(found.uv) == len(truth)
        assert miss(found.uv, truth)[covered].mean() > 1.4  # the visible part's middle
        published = found.centre if found.centre is not None else found.uv
        err = miss(published, truth)
        assert err[covered].mean() < 0.7, f'covered markers {err[covered].mean():.2f} px off'
        assert err[~covered].mean() < 0.35, f'whole markers {err[~covered].mean():.2f} px off'


def test_without_the_up_direction_nothing_moves() -> None:
    """No up direction (the default without a calibration): no published centre of its own."""
    truth, _, jpeg = frame(3, 0.5)
    found = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS)).detect_jpeg(jpeg)
    assert found.centre is None and len(found.uv) == len(truth)


def test_a_steep_view_moves_nothing() -> None:
    """Seen from more than ``MAX_ELEVATION_DEG`` above the sand a covered marker's centroid lies
    near its centre, nearer than the mass's noise: the published centres are the centroids."""
    _, _, jpeg = frame(3, 0.5)
    found = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS, up_px=UP,
                                          view_elevation_deg=MAX_ELEVATION_DEG + 10)
                           ).detect_jpeg(jpeg)
    assert found.centre is not None and np.array_equal(found.centre, found.uv)


def test_published_points_take_the_centre_and_tracking_keeps_the_centroid() -> None:
    """The tracker's points that are detections go out at their marker centres, in the
    tracker's order; a point that is no detection (a faint spot) goes out as tracked."""
    _, _, jpeg = frame(4, 0.5)
    found = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS, up_px=UP)
                           ).detect_jpeg(jpeg)
    assert found.centre is not None
    assert not np.allclose(found.centre, found.uv)  # some moved
    faint = np.array([[5.5, 7.25]])
    tracked = np.vstack([found.uv[::-1], faint])
    out = published_centres(found, tracked)
    assert np.array_equal(out[:-1], found.centre[::-1])
    assert np.array_equal(out[-1], faint[0])
    assert np.array_equal(tracked[:-1], found.uv[::-1])  # the tracker's own points unchanged


def test_an_up_direction_that_is_no_unit_vector_is_refused() -> None:
    """up_px must be a unit vector (or (0, 0)): one clear error naming it."""
    with pytest.raises(ValueError, match='up_px'):
        DetectorConfig(up_px=(0.5, 0.5))
    with pytest.raises(ValueError, match='view_elevation_deg'):
        DetectorConfig(view_elevation_deg=120.0)


def test_each_camera_gets_world_up_from_its_calibration(rig) -> None:
    """The two-camera tracker gives each detector the image direction of world up at the
    grid (the twin's cameras look down at the bed: up is up the image, within 30 degrees),
    a unit vector, and the line of sight's elevation; with ``uncover`` off, none."""
    from dempath_recon.tracking.associate import MarkerGrid, project
    from dempath_recon.tracking.stereo import StereoTrackConfig, camera_detectors

    cams = {c.name: c for c in rig.cameras}
    grid = MarkerGrid(layout_m=((0.0, 0.0, 0.0), (0.03, 0.0, 0.0)))
    on = camera_detectors(cams, StereoTrackConfig(grid=grid))
    for name, det in on.items():
        up = np.array(det.config.up_px)
        assert np.hypot(*up) == pytest.approx(1.0)
        assert up[1] < -np.cos(np.radians(30))
        a, b = project(cams[name], np.array([[0.015, 0.0, 0.0], [0.015, 0.005, 0.0]]))
        assert np.dot(b - a, up) / np.hypot(*(b - a)) > 0.999  # that is where up projects
        centre = -np.asarray(cams[name].R).T @ np.asarray(cams[name].t).ravel()
        sight = np.array([0.015, 0.0, 0.0]) - centre
        elevation = np.degrees(np.arcsin(-sight[1] / np.linalg.norm(sight)))
        assert det.config.view_elevation_deg == pytest.approx(elevation, abs=1e-6)
        assert 10 < elevation < 90
    off = camera_detectors(cams, StereoTrackConfig(grid=grid, uncover=False))
    assert all(det.config.up_px == (0.0, 0.0) for det in off.values())


def test_shake_moves_the_published_centres_with_the_detections() -> None:
    """A frame's shake taken off its detections is taken off their published centres too:
    each centre keeps its offset from its detection."""
    from dempath_recon.tracking.shake import remove_shake

    _, _, jpeg = frame(4, 0.5)
    found = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS, up_px=UP)
                           ).detect_jpeg(jpeg)
    assert found.centre is not None
    moved = remove_shake(found, np.array([2.5, -1.25]))
    assert moved.centre is not None
    assert np.allclose(moved.centre - moved.uv, found.centre - found.uv)
    assert np.allclose(published_centres(moved, moved.uv), found.centre - [2.5, -1.25])



RED_CLAY = (0.15, 0.18, 0.62)  # B, G, R albedo
SLATE = (0.42, 0.44, 0.47)


def test_another_clays_noisy_peak_pixel_does_not_move_a_whole_marker() -> None:
    """Red clay on slate sand: whole markers each with one hot pixel at their centre (a peak
    pixel of another clay's axis reads far above its clay, as JPEG noise and highlights make
    it on the renders) are whole by their chroma mass and stay where their centroid is, while
    covered markers still move to their disc centre; divided by the peak pixel, as blue clay's
    share is, the whole markers would read half covered and move down by 1-2 px."""
    rng = np.random.default_rng(22)
    gx, gy = np.meshgrid(np.arange(30, 300, 40), np.arange(30, 220, 40))
    truth = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-5, 5, (gx.size, 2))
    covered = np.arange(len(truth)) % 3 == 0
    hot = np.arange(len(truth)) % 3 == 1
    jpeg = spot_image(SHAPE, truth, RADIUS, rng, buried=np.where(covered, 0.45, 0.0),
                      noise_dn=2.0, quality=85, sand_bgr=np.array(SLATE),
                      clay_bgr=np.array(RED_CLAY))
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    for x, y in np.round(truth[hot]).astype(int):  # a 2 x 2 block: one half-size pixel
        x0, y0 = x - x % 2, y - y % 2
        image[y0:y0 + 2, x0:x0 + 2] = (12, 24, 250)
    config = DetectorConfig(marker_diameter_px=2 * RADIUS, up_px=UP, view_elevation_deg=30.0,
                            marker_bgr=RED_CLAY, sand_bgr=SLATE)
    found = MarkerDetector(config).detect(image)
    assert found.centre is not None and len(found.uv) == len(truth)
    at = np.linalg.norm(truth[:, None] - found.uv[None], axis=2).argmin(axis=1)
    moved = np.linalg.norm(found.centre[at] - found.uv[at], axis=1)
    assert moved[hot].max() < 0.3, moved[hot]
    assert miss(found.centre, truth[hot]).mean() < 0.6
    assert miss(found.centre, truth[covered]).mean() < miss(found.uv, truth[covered]).mean() - 0.3
