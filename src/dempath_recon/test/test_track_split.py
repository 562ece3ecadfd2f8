"""A spot two numbered tracks predict is split where they say (``tracking.track_split``).

The side camera's frame is rendered (``spots.spot_image``, full size, JPEG, the detector's own
pass, its discs cut by the sand along the view's up direction): marker 8 and a neighbour placed
``GAP_M`` beside it along Z, a third buried and smeared by its motion during the exposure (a
fast marker half in the sand), run into one spot whose centre lies between them (the
detector's own split does not part it). The side's tracks of 8 and 16 (the neighbour) are seeded at
their true places; the front camera places both (its sightings at this instant).
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from projected import GRID15
from spots import spot_image

from dempath_recon.tracking import track_split
from dempath_recon.tracking.associate import (
    MarkerGrid,
    epipolar_distance,
    marker_diameter_px,
    view_of_up,
)
from dempath_recon.tracking.detect import Detections, DetectorConfig, MarkerDetector
from dempath_recon.tracking.state import StereoState
from dempath_recon.tracking.stereo import StereoTrackConfig
from dempath_recon.tracking.track_split import lines_agree, split_by_tracks

CONFIG = StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15))
GAP_M = 0.0055  # the neighbour's distance from marker 8 along Z [m]: 5.8 px in the side image
# (0.7 marker diameters)
BURIED = 0.3  # the neighbour's share of its height below the sand
STREAK = (0.0, 6.0)  # the neighbour's motion during the exposure [px]
STAMP = 0.02
NEIGHBOUR = 16


def places(rig) -> dict[str, np.ndarray]:
    """Each camera's (2, 2) px of marker 8 and its neighbour."""
    xyz = np.array([GRID15[7], np.add(GRID15[7], (0.0, 0.0, GAP_M))])
    return {c.name: c.project(xyz) for c in rig.cameras}


@pytest.fixture(scope='module')
def merged(rig) -> tuple[Detections, MarkerDetector]:
    """The side's detections of a frame where 8 and its neighbour touch, and its detector."""
    side = rig.cameras[0]
    diameter = marker_diameter_px(side, CONFIG.grid, CONFIG.marker_diameter_m)
    uv = np.vstack([side.project(np.delete(np.array(GRID15), 7, axis=0)), places(rig)[
        'cam_side']])
    buried = np.zeros(len(uv))
    buried[-1] = BURIED
    jpeg = spot_image((side.height, side.width), uv, 0.5 * diameter, np.random.default_rng(5),
                      quality=92, buried=buried, streak=STREAK)
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    up, elevation = view_of_up(side, CONFIG.grid)
    detector = MarkerDetector(DetectorConfig(marker_diameter_px=diameter, up_px=up,
                                             view_elevation_deg=elevation))
    return detector.detect(image), detector


def state_with(rig, front: np.ndarray, tracked: tuple[int, ...] = (8, NEIGHBOUR),
               ) -> StereoState:
    """The tracker's state: the side's numbered tracks of ``tracked`` standing at their true
    places, the front's sightings of 8 and the neighbour at ``front`` (2, 2) px."""
    state = StereoState.start({c.name: c for c in rig.cameras}, CONFIG)
    side = places(rig)['cam_side']
    keep = [k for k, m in enumerate((8, NEIGHBOUR)) if m in tracked]
    state.trackers['cam_side'].seed(side[keep], np.array(tracked, np.int32), 0.0)
    state.latest['cam_front'] = {8: (STAMP, front[0]), NEIGHBOUR: (STAMP, front[1])}
    return state


def split(rig, merged, state: StereoState) -> tuple[Detections, dict, list[str]]:
    """The side frame through the step."""
    det, detector = merged
    cfg = detector.config
    events: list[str] = []
    out, barred = split_by_tracks(state, 'cam_side', det, STAMP, cfg.marker_diameter_px,
                                  cfg.downscale, cfg.threshold, detector.cut_up, None, events)
    return out, barred, events


def nearest(det: Detections, where: np.ndarray) -> np.ndarray:
    """(k,) the distance [px] from each point of ``where`` (k, 2) to the nearest published
    marker centre (``Detections.centre``: a covered marker's disc centre)."""
    centre = det.uv if det.centre is None else det.centre
    return np.linalg.norm(centre[None] - where[:, None], axis=2).min(axis=1)


def test_the_detector_alone_leaves_one_spot_between_them(rig, merged) -> None:
    """The scene is a merge: one detection, more than 1.5 px from both markers."""
    det, _ = merged
    side = places(rig)['cam_side']
    near = np.linalg.norm(det.uv[:, None] - side[None], axis=2)
    assert (near.min(axis=0) > 1.5).all() and (near.min(axis=1) < 6.0).sum() == 1


def test_a_spot_both_tracks_predict_is_split_at_their_markers(rig, merged) -> None:
    """Both tracks predict inside the one spot and the front places both on their lines: two
    markers within 1 px of the truth, each track barred from the other's."""
    out, barred, events = split(rig, merged, state_with(rig, places(rig)['cam_front']))
    side = places(rig)['cam_side']
    assert len(out.uv) == len(merged[0].uv) + 1
    assert (nearest(out, side) < 1.0).all(), nearest(out, side)
    assert (nearest(merged[0], side) > 1.5).all()
    assert len(barred) == 2 and all(b.sum() == 1 for b in barred.values())
    assert any('split' in e for e in events)


def test_without_the_fit_s_gain_nothing_is_split(rig, merged, monkeypatch) -> None:
    """The rule off (the two discs never believed): the spot stays one."""
    monkeypatch.setattr(track_split, 'GAIN', 1e9)
    out, barred, _ = split(rig, merged, state_with(rig, places(rig)['cam_front']))
    assert len(out.uv) == len(merged[0].uv) and not barred


def test_a_centre_off_its_number_s_line_keeps_the_spot_whole(rig, merged) -> None:
    """The front's sighting of the neighbour moved 8 px down its column: the fitted centre
    lies off that line, so the spot is not split (both are withheld later, as before)."""
    front = places(rig)['cam_front'].copy()
    front[1] += (0.0, 8.0)
    side, cam_front = rig.cameras
    assert epipolar_distance(cam_front, side, front[1:], places(rig)['cam_side'][1:])[0, 0] > 5
    out, barred, _ = split(rig, merged, state_with(rig, front))
    assert len(out.uv) == len(merged[0].uv) and not barred


def test_a_number_only_the_other_camera_places_is_split_out_on_its_line(rig, merged) -> None:
    """Only 8 has a track in the side; the front places the neighbour, whose line crosses the
    wide spot: two markers, the new one without a track (no bar for it)."""
    state = state_with(rig, places(rig)['cam_front'], tracked=(8,))
    out, barred, _ = split(rig, merged, state)
    side = places(rig)['cam_side']
    assert (nearest(out, side) < 1.0).all(), nearest(out, side)
    assert list(barred) == [state.trackers['cam_side'].tracks[0].track_id]


def test_lines_tell_points_apart_only_when_they_are_apart(rig) -> None:
    """``lines_agree``: each point on its own partner's line passes, the two swapped fail."""
    side, front = rig.cameras
    xyz = np.array([GRID15[2], GRID15[12]])
    uv, other = side.project(xyz), front.project(xyz)
    assert lines_agree(front, side, other, uv, 4.0)
    assert not lines_agree(front, side, other, uv[::-1], 4.0)
