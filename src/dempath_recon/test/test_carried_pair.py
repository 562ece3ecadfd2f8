"""A marker the side camera first sees mid-pass, while the front has numbered it since the grid
fit (``tracking.carried_pair``): its spot lies on the front's line of that marker, and the pair's
3D point is where the bed has carried the marker (moved as its tracked neighbours moved), so it
takes that number from its first frame, though its grid point no longer bounds the depth (the
fit is more than ``MAX_DEPTH_AGE_S`` old). Where a marker nobody sees has been carried about as
near the pair's point, the spot waits.

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
from projected import DT, GRID15, feed_frame, numbers_given

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.state import MAX_DEPTH_AGE_S
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

FLOW = np.array([0.0, 0.0005, 0.001])  # the bed's slow heave [m/frame]
FRAMES = 12
OUT_AT = 6  # the side camera sees marker 8 from this frame on


def _side_numbers_of_eight(rig, moved: np.ndarray, hidden: tuple[int, ...],
                           carried_pair: bool) -> list[int]:
    """The number the side gives marker 8's spot in each of its frames from ``OUT_AT``: 8 is
    moved by ``moved`` (a clod) and covered in the side view until then; the markers of
    ``hidden`` are seen by neither camera; the front sees every other marker throughout."""
    cams = {c.name: c for c in rig.cameras}
    start = np.array(GRID15)
    start[7] += moved
    config = replace(StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)),
                     carried_pair=carried_pair)
    tracker = StereoMarkerTracker(cams, config)
    out = []
    for k in range(FRAMES):
        pts = start + k * FLOW
        side_hides = set(hidden) | ({8} if k < OUT_AT else set())
        side = [p for m, p in enumerate(pts, 1) if m not in side_hides]
        front = [p for m, p in enumerate(pts, 1) if m not in hidden]
        out += feed_frame(tracker, cams, k, side, front)
    out += tracker.flush()
    got = numbers_given(out, cams['cam_side'], lambda k: start[7] + k * FLOW, OUT_AT)
    for f in out:  # nobody took a number twice
        assert len(set(f.markers[f.markers >= 0].tolist())) == int((f.markers >= 0).sum())
    return got


def test_the_scene_comes_out_after_the_grid_point_stops_bounding_the_depth() -> None:
    assert OUT_AT * DT > MAX_DEPTH_AGE_S


@pytest.mark.parametrize('carried_pair', [False, True])
def test_a_marker_coming_out_in_one_camera_takes_the_others_number(rig,
                                                                   carried_pair: bool) -> None:
    got = _side_numbers_of_eight(rig, np.zeros(3), (), carried_pair)
    if not carried_pair:  # the epipolar numbering cannot check the depth: it waits
        assert set(got) == {-1}
        return
    assert set(got) == {8}  # from its first frame (the publication delay)


def test_a_spot_a_marker_nobody_sees_may_be_waits(rig) -> None:
    """Marker 8 came out 12 mm toward marker 9's place, and 9 is seen by neither camera:
    its carried place is about as near the pair's point as 8's."""
    moved = np.array([0.0, 0.0, 0.0125])
    assert set(_side_numbers_of_eight(rig, moved, (9,), True)) == {-1}
