"""A marker only one camera sees, refused at the grid fit, numbered by elimination
(``tracking.grid_elimination``): the bed moved marker 8 7 mm up and 7 mm forward before the
first frame, so the side camera's grid fit leaves its spot unnumbered (a neighbour's grid point
lies nearly as near), and the front camera never sees it. Its neighbours are all numbered, so
among the markers nobody holds its own grid point is by far the nearest: it takes 8. Where a
second marker nobody holds (9, seen by neither camera) has its grid point about as near, the
spot waits.

Scenes are 3D points projected through the twin's true cameras, so each detection's marker
is known.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from projected import DT, GRID15, OFFSET, numbers_given, run_scene
from projected import exact_detections as _dets

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.grid_elimination import revoke_jumped, revoke_shared
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

FLOW = np.array([0.0, 0.0005, 0.001])  # the bed's slow heave before the tool arrives [m/frame]
FRAMES = 10


def _run(rig, moved: np.ndarray, side_hides: tuple[int, ...], elimination: bool) -> list:
    """Released frames of a pass: markers on GRID15 (marker 8 moved by ``moved``) flowing
    slowly; the front never sees 8 nor any of ``side_hides``; the side sees all but those."""
    start = np.array(GRID15)
    start[7] += moved
    config = replace(StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)),
                     elimination=elimination)
    hidden_front = {8, *side_hides}

    def frame(k: int) -> tuple[list, list]:
        pts = start + k * FLOW
        return ([p for m, p in enumerate(pts, 1) if m not in side_hides],
                [p for m, p in enumerate(pts, 1) if m not in hidden_front])

    return run_scene(rig, config, map(frame, range(FRAMES)))[0]


def _side_numbers_of_eight(rig, out: list, moved: np.ndarray) -> list[int]:
    """The number the side gave marker 8's spot in each of its frames."""
    return numbers_given(out, rig.cameras[0], lambda k: np.array(GRID15[7]) + moved + k * FLOW)


MOVED = np.array([0.0, 0.007, 0.007])


@pytest.mark.parametrize('elimination', [False, True])
def test_spot_only_one_camera_sees_is_numbered_by_elimination(rig, elimination: bool) -> None:
    out = _run(rig, MOVED, (), elimination)
    got = _side_numbers_of_eight(rig, out, MOVED)
    if not elimination:  # the grid fit alone leaves it unnumbered the whole pass
        assert set(got) == {-1}
        return
    assert set(got) == {8}  # from the first frame given out (the publication delay)
    for f in out:  # and nobody else took a wrong number
        assert len(set(f.markers[f.markers >= 0].tolist())) == int((f.markers >= 0).sum())


def test_spot_between_two_markers_nobody_holds_waits(rig) -> None:
    moved = np.array([0.0, 0.004, 0.01])  # 10 mm toward marker 9's grid point
    out = _run(rig, moved, (9,), elimination=True)
    assert set(_side_numbers_of_eight(rig, out, moved)) == {-1}


def _numbered_eight(rig) -> tuple[StereoMarkerTracker, int]:
    """A tracker after the pass above, and the side's track that took 8 by elimination."""
    cams = {c.name: c for c in rig.cameras}
    start = np.array(GRID15)
    start[7] += MOVED
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)))
    for k in range(4):
        pts = start + k * FLOW
        tracker.update_detections('cam_side', k * DT, _dets(cams['cam_side'], pts))
        tracker.update_detections('cam_front', k * DT + OFFSET,
                                  _dets(cams['cam_front'], np.delete(pts, 7, axis=0)))
    (tid,) = tracker.state.eliminated['cam_side']
    return tracker, tid


def test_a_number_by_elimination_is_given_back_when_its_spot_is_shared(rig) -> None:
    tracker, tid = _numbered_eight(rig)
    state = tracker.state
    ids = np.array([t.track_id for t in state.trackers['cam_side'].tracks])
    revoke_shared(state, 'cam_side', ids, ids == tid, [])
    track = next(t for t in state.trackers['cam_side'].tracks if t.track_id == tid)
    assert track.marker == -1 and (tid, 8) in state.refused['cam_side']
    assert tid not in state.eliminated['cam_side']


def test_a_number_by_elimination_is_given_back_when_its_track_jumps(rig) -> None:
    tracker, tid = _numbered_eight(rig)
    state = tracker.state
    ids = np.array([t.track_id for t in state.trackers['cam_side'].tracks])
    markers = np.array([t.marker for t in state.trackers['cam_side'].tracks], np.int32)
    assert (revoke_jumped(state, 'cam_side', ids, markers, []) == markers).all()  # smooth
    track = next(t for t in state.trackers['cam_side'].tracks if t.track_id == tid)
    track.link_px = 2 * state.config.doubt_link_px  # a link far off its prediction
    out = revoke_jumped(state, 'cam_side', ids, markers, [])
    assert out[ids == tid][0] == -1 and track.marker == -1
    assert (out[ids != tid] == markers[ids != tid]).all()
