"""A grid pair whose number the first camera's own grid gave its spot differently is not given
(``tracking.pair_anchor.drop_contested``), on the detections of a faint rendered look's first
frames (light x0.5, 12 ms, JPEG 70) and on plain numbers."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from dempath_calib.camera import CameraModel
from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.pair_anchor import drop_contested
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

sys.path.insert(0, str(Path(__file__).parent))
from test_pair_anchor import owner

DATA = Path(__file__).parent / 'data' / 'faint_first_frames.json'


def look() -> dict[str, Any]:
    """The render's cameras, grid and first frame of each camera (detections and truth)."""
    out: dict[str, Any] = json.loads(DATA.read_text())
    return out


def numbered(tracker: StereoMarkerTracker, frame: dict[str, Any],
             ids: list[int]) -> dict[int, int]:
    """The number each of a camera's first-frame spots' tracks holds, by the spot's marker."""
    truth = owner(frame, ids)
    out = {}
    for t in tracker.state.trackers[frame['camera']].tracks:
        d = np.linalg.norm(np.array(frame['uv']) - np.asarray(t.uv), axis=1)
        if d.min() < 0.5:
            out[int(truth[int(d.argmin())])] = t.marker
    return out


def test_a_ghost_pair_at_the_first_fit_is_not_given() -> None:
    """The side camera numbers its spot of marker 9 by its own grid; that spot and the front
    camera's spot of marker 13 lie on each other's epipolar lines and meet near grid point 14
    (a ghost pair). Through the two-camera tracker neither spot takes 14, nor any number but
    its own marker's, and the side's 9 is not replaced."""
    data = look()
    cams = {c['name']: CameraModel.from_dict(c) for c in data['cameras']}
    grid = MarkerGrid(layout_m=tuple(tuple(p) for p in data['marker_grid_m']))
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=grid))
    side, front = data['frames']
    frame = tracker.update_detections(side['camera'], side['stamp_s'], Detections(
        np.array(side['uv']), np.array(side['confidence']), np.array(side['size_px'])))
    alone = dict(zip(owner(side, data['marker_ids']).tolist(), frame.markers.tolist(),
                     strict=True))
    assert alone[9] == 9  # the cause, as rendered: the side's own grid numbers it rightly
    tracker.update_detections(front['camera'], front['stamp_s'], Detections(
        np.array(front['uv']), np.array(front['confidence']), np.array(front['size_px'])))
    for cam_frame in (side, front):
        got = numbered(tracker, cam_frame, data['marker_ids'])
        wrong = {m: g for m, g in got.items() if g >= 0 and g != m}
        assert not wrong, (cam_frame['camera'], wrong)
    assert numbered(tracker, side, data['marker_ids'])[9] in (9, -1)
    assert numbered(tracker, front, data['marker_ids'])[13] != 14


def test_only_the_contested_pair_waits() -> None:
    """A pair numbered 14 on a spot the first camera numbered 9 is dropped in both cameras;
    pairs that agree with it, or that it left unnumbered, stay."""
    mine = np.array([2, 14, 8, -1], np.int32)
    theirs = np.array([2, 8, 14, 5], np.int32)
    alone = np.array([2, 8, 9, -1], np.int32)
    events: list[str] = []
    a, b = drop_contested(mine, theirs, alone, 'cam_front', 'cam_side', events)
    assert a.tolist() == [2, -1, 8, -1]
    assert b.tolist() == [2, 8, -1, 5]
    assert len(events) == 1 and '14' in events[0]
    assert mine.tolist() == [2, 14, 8, -1]  # inputs left as they were


def test_a_grid_that_slipped_a_pitch_gives_way_to_the_pairs() -> None:
    """When the pairs contradict the first camera's own grid on most spots both number (its
    fit slipped a pitch), every pair keeps its number."""
    mine = np.array([3, 4, 5], np.int32)
    theirs = np.array([3, 4, 5], np.int32)
    alone = np.array([4, 5, 6], np.int32)
    a, b = drop_contested(mine, theirs, alone, 'cam_front', 'cam_side', [])
    assert a.tolist() == [3, 4, 5] and b.tolist() == [3, 4, 5]
