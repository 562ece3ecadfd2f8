"""Elimination is not held back by a spot of the other camera that lies on the track's epipolar
line but pairs with it far from every free marker (``tracking.line_rival``): marker 8, moved by
the bed before the first frame so the side's grid fit leaves it unnumbered, is hidden from the
front; the front instead shows a stray spot on 8's line of sight in the side, 60 mm nearer the
side camera. Without the rule elimination defers to the pair rules, which give the stray spot
and the side's spot out as 8 together (a pair 60 mm off); with it the side's spot is 8 by
elimination and the stray spot stays unnumbered. Likewise a marker the front gives out near the
line (11, hidden from the side) no longer holds 8 back when their pair is far from 11. A spot
whose pair lies near 8's carried place (it may be 8) still defers.

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
from projected import DT, GRID15, feed_frame, numbers_given, run_scene

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.grid_elimination import LINE_FACTOR
from dempath_recon.tracking.line_rival import (
    RIVAL_GATE_M,
    may_be_free,
    may_be_given,
    neighbours_settled,
)
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

FLOW = np.array([0.0, 0.0005, 0.001])  # the bed's slow heave [m/frame]
MOVED = np.array([0.0, 0.007, 0.007])  # marker 8 before the first frame [m]
STRAY_M = 0.06  # the front's stray spot lies this far from 8 towards the side camera [m]
FRAMES = 10


def _eight(k: int) -> np.ndarray:
    """Marker 8 at frame ``k`` [m]."""
    return np.array(GRID15[7]) + k * FLOW + MOVED


def _on_side_ray(rig, point: np.ndarray, toward_m: float) -> np.ndarray:
    """The point ``toward_m`` [m] from ``point`` (3,) m along the side camera's line of sight
    through it, towards the camera (same pixel in the side, on its epipolar line in the
    front)."""
    side = rig.cameras[0]
    centre = -np.asarray(side.R).T @ np.asarray(side.t)
    return point + toward_m * (centre - point) / np.linalg.norm(centre - point)


def _run(rig, line_rival: bool, hidden_from_side: int = 0) -> list:
    """Released frames of the pass, ``line_rival`` as given: 8 hidden from the front; with
    ``hidden_from_side`` 0 the front shows the stray spot (module docstring), else that marker
    is hidden from the side instead."""
    config = replace(StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)), line_rival=line_rival)

    def frame(k: int) -> tuple[list, list]:
        pts = np.array(GRID15) + k * FLOW
        pts[7] = _eight(k)
        side = [p for m, p in enumerate(pts, 1) if m != hidden_from_side]
        front = [p for m, p in enumerate(pts, 1) if m != 8]
        if not hidden_from_side:
            front.append(_on_side_ray(rig, pts[7], STRAY_M))
        return side, front

    return run_scene(rig, config, map(frame, range(FRAMES)))[0]


@pytest.mark.parametrize('line_rival', [False, True])
def test_a_stray_spot_on_the_line_does_not_hold_back_elimination(rig, line_rival: bool) -> None:
    """Without the rule the stray spot and the side's spot go out as 8 in every frame; with it
    the side gives 8 on its own spot and the front's stray spot is never numbered."""
    out = _run(rig, line_rival)
    side = numbers_given(out, rig.cameras[0], _eight)
    stray = numbers_given(out, rig.cameras[1], lambda k: _on_side_ray(rig, _eight(k), STRAY_M))
    if not line_rival:
        assert set(side) == {8} and set(stray) == {8}  # the premise: a pair 60 mm off
        return
    assert set(side) == {8} and set(stray) == {-1}


@pytest.mark.parametrize('line_rival', [False, True])
def test_a_marker_the_front_gives_out_near_the_line_does_not_hold_back_elimination(
        rig, line_rival: bool) -> None:
    """Marker 11, hidden from the side, is given out by the front 7 px from the epipolar line
    of the side's spot of 8 (within elimination's reach for a marker coming out of the sand),
    but their pair lies far from where the bed carried 11: with the rule the side gives 8
    (without it 8 stays unnumbered), and the front's 11 keeps its number either way."""
    out = _run(rig, line_rival, hidden_from_side=11)
    side = numbers_given(out, rig.cameras[0], _eight)
    front = numbers_given(out, rig.cameras[1], lambda k: np.array(GRID15[10]) + k * FLOW)
    assert set(front) == {11}
    assert set(side) == ({8} if line_rival else {-1})


def test_a_spot_that_may_be_the_marker_still_defers(rig) -> None:
    """After the grid fit (8 free: hidden from the front, unnumbered in the side), a front spot
    on the line of the side's spot of 8 defers when its pair lies within the gate of 8's
    carried place, and not when it lies 60 mm off; so does a spot the front gives out as 8
    (it fails with ``RIVAL_GATE_M`` at 0.1 m)."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)))
    pts = np.array(GRID15)
    pts[7] = _eight(0)
    feed_frame(tracker, cams, 0, list(pts), [p for m, p in enumerate(pts, 1) if m != 8])
    state, uv = tracker.state, rig.cameras[0].project(pts[7][None])[0]
    near = rig.cameras[1].project(_on_side_ray(rig, pts[7], 0.5 * RIVAL_GATE_M)[None])
    far = rig.cameras[1].project(_on_side_ray(rig, pts[7], STRAY_M)[None])
    assert 8 not in {t.marker for c in state.cameras for t in state.trackers[c].tracks}
    assert may_be_free(state, 'cam_side', uv, near, DT)
    assert not may_be_free(state, 'cam_side', uv, far, DT)
    gate = LINE_FACTOR * state.config.epipolar_px  # elimination's reach for a given marker
    assert may_be_given(state, 'cam_side', uv, {8: near[0]}, gate, DT)
    assert not may_be_given(state, 'cam_side', uv, {8: far[0]}, gate, DT)


def test_a_neighbour_with_a_fresh_pair_number_is_not_settled(rig) -> None:
    """A neighbour counts as settled on its own spot when the track giving it out took its
    number at the grid fit, not when that number is a late one still on probation
    (``state.late_numbered``): such a number may be the mistake that made the track look
    free of it."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)))
    pts = np.array(GRID15)
    for k in range(2):
        feed_frame(tracker, cams, k, list(pts + k * FLOW), list(pts + k * FLOW))
    state = tracker.state
    tracks = [t for t in state.trackers['cam_front'].tracks if t.marker >= 0]
    track_ids = np.array([t.track_id for t in tracks], np.int64)
    markers = np.array([t.marker for t in tracks], np.int32)
    assert neighbours_settled(state, 'cam_front', track_ids, markers, [7, 9])
    assert not neighbours_settled(state, 'cam_front', track_ids, markers, [7, 16])  # not seen
    state.late_numbered['cam_front'].add(int(track_ids[markers == 9][0]))
    assert not neighbours_settled(state, 'cam_front', track_ids, markers, [7, 9])
