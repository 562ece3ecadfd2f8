"""Guided recovery (``tracking.guided``): a marker under the detector's threshold in one camera
is looked for only on the other camera's epipolar line of that marker, and keeps its number.

The side camera's frames are rendered (``spots.spot_image``, full size, JPEG) with marker 8
blended into the sand at ``FADED`` of its contrast (under the threshold, above the faint bar:
a half-buried marker at dusk); the front camera sees all 15 markers (exact detections). The
scene stands still, so one side frame serves every instant.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from projected import DT, GRID15, OFFSET, exact_detections
from spots import spot_image

from dempath_recon.tracking.associate import (
    MarkerGrid,
    back_project,
    depth,
    epipolar_distance,
    marker_diameter_px,
)
from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector
from dempath_recon.tracking.guided import claimed, line_near, line_spot, rival_lines, stale
from dempath_recon.tracking.state import StereoState
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

FADED = 0.58  # marker 8's share of its contrast in the side: a faint spot, not a detection
FRAMES = 8
CONFIG = StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15))


def side_frame(rig, shift_px: np.ndarray) -> np.ndarray:
    """The side camera's BGR frame: the 15 markers, marker 8 faded and ``shift_px`` (2,) off
    its own place."""
    side = rig.cameras[0]
    uv = side.project(np.array(GRID15))
    radius = 0.5 * marker_diameter_px(side, CONFIG.grid, CONFIG.marker_diameter_m)
    moved = uv.copy()
    moved[7] += shift_px

    def render(centres: np.ndarray) -> np.ndarray:
        jpeg = spot_image((side.height, side.width), centres, radius, np.random.default_rng(3),
                          quality=95)
        return cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR).astype(float)

    both, rest = render(moved), render(np.delete(uv, 7, axis=0))
    return np.clip(rest * (1 - FADED) + both * FADED, 0, 255).astype(np.uint8)


def side_numbers(rig, image: np.ndarray, guided: bool, where: np.ndarray) -> list[int]:
    """The number the side gave the point nearest ``where`` (2,) px in each released frame
    (-2: no point within 2 px)."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, replace(CONFIG, guided=guided))
    front = exact_detections(cams['cam_front'], np.array(GRID15))
    out = []
    for k in range(FRAMES):
        tracker.update_image('cam_side', k * DT, image)
        out += tracker.release()
        tracker.update_detections('cam_front', k * DT + OFFSET, front)
        out += tracker.release()
    got = []
    for f in sorted(out + tracker.flush(), key=lambda f: f.stamp_s):
        if f.camera != 'cam_side':
            continue
        d = np.linalg.norm(f.uv - where, axis=1) if len(f.uv) else np.array([np.inf])
        got.append(int(f.markers[int(np.argmin(d))]) if d.min() < 2.0 else -2)
    return got


@pytest.fixture(scope='module')
def faded(rig) -> np.ndarray:
    """The side frame with marker 8 faded at its own place."""
    return side_frame(rig, np.zeros(2))


def test_a_faint_marker_on_the_other_cameras_line_keeps_its_number(rig, faded) -> None:
    """With the rule, the side gives out 8 at its faint spot once the front has numbered it
    (from the second frame); without it the spot is never found, so never numbered."""
    where = rig.cameras[0].project(np.array([GRID15[7]]))[0]
    assert set(side_numbers(rig, faded, False, where)) == {-2}
    got = side_numbers(rig, faded, True, where)
    assert got[0] == -2 and set(got[1:]) == {8}, got


def test_a_faint_spot_off_the_line_is_not_taken(rig, faded) -> None:
    """The faded marker 8 is found on the front's line of 8; asked with a front point whose
    line passes 6 px beside it (well within the search radius of where 8 was), nothing is
    found: the spot must lie on the other camera's line, not just near the place."""
    side, front = rig.cameras
    state = StereoState.start({c.name: c for c in rig.cameras}, CONFIG)
    det = MarkerDetector(DetectorConfig(marker_diameter_px=marker_diameter_px(
        side, CONFIG.grid, CONFIG.marker_diameter_m))).detect(faded)
    uv8 = side.project(np.array([GRID15[7]]))[0]
    partner = front.project(np.array([GRID15[7]]))[0]
    spot = line_spot(state, 'cam_side', det, partner, uv8, 12.0)
    assert spot is not None and np.linalg.norm(spot - uv8) < 1.0
    _, direction = line_near(side, front, partner, uv8)
    beside = uv8 + 6.0 * np.array([direction[1], -direction[0]])
    elsewhere = back_project(side, beside, depth(side, np.array(GRID15[7])))
    moved = front.project(elsewhere[None])[0]
    assert abs(epipolar_distance(front, side, moved[None], uv8[None])[0, 0] - 6.0) < 0.5
    assert line_spot(state, 'cam_side', det, moved, uv8, 12.0) is None


def test_a_spot_on_the_line_of_another_marker_the_other_camera_sees_is_refused(rig) -> None:
    """A spot on the front's lines of both 8 and 3 (3 at another depth on the side's ray) could
    be either: refused while the side holds 3 nowhere, taken once it holds 3 elsewhere."""
    side, front = rig.cameras
    cams = {c.name: c for c in rig.cameras}
    state = StereoState.start(cams, CONFIG)
    spot = side.project(np.array([GRID15[7]]))[0]
    ray_point = back_project(side, spot, 0.9 * depth(side, np.array(GRID15[7])))
    state.latest['cam_front'] = {8: (0.0, front.project(np.array([GRID15[7]]))[0]),
                                 3: (0.0, front.project(ray_point[None])[0])}
    assert rival_lines(state, 'cam_side', 8, spot, set(), 0.003)
    assert not rival_lines(state, 'cam_side', 8, spot, {3}, 0.003)
    del state.latest['cam_front'][3]
    assert not rival_lines(state, 'cam_side', 8, spot, set(), 0.003)


def test_a_spot_another_lost_track_predicts_or_an_old_position_is_refused(rig) -> None:
    """``claimed``: a lost track of another number predicting the spot within a marker's width
    claims it (its marker may be back), its own track does not; ``stale``: a marker whose last
    3D position is older than three frames has nothing left to place it, one never
    triangulated is placed by its grid point alone."""
    cams = {c.name: c for c in rig.cameras}
    state = StereoState.start(cams, CONFIG)
    tracker = state.trackers['cam_side']
    spot = np.array([950.0, 550.0])
    tracker.seed(np.array([[953.0, 551.0]]), np.array([3], np.int32), 0.0)
    tracker.tracks[0].lost = True
    assert claimed(state, 'cam_side', 8, spot, 0.02)
    assert not claimed(state, 'cam_side', 3, spot, 0.02)
    assert not claimed(state, 'cam_side', 8, spot + np.array([20.0, 0.0]), 0.02)
    state.positions.accept(8, 0.0, np.array(GRID15[7]))
    assert not stale(state, 8, 0.06) and stale(state, 8, 0.08)
    assert not stale(state, 9, 0.08)


def test_a_bad_search_radius_is_refused() -> None:
    """``guided_px`` must be a positive radius under 100 px: one error line naming it."""
    for bad in (0.0, -3.0, 150.0):
        with pytest.raises(ValueError, match='guided_px'):
            StereoTrackConfig(guided_px=bad)
