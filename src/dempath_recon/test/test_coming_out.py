"""A marker coming out of the sand mid-pass in one camera only (``tracking.coming_out``): the bed
flows 4 mm a frame along Z; marker 8 is covered in both cameras at the grid fit and comes out
in the side camera only at frame 6, 24 mm from its grid point (too far for the late grid rule,
too late for elimination). Its neighbours, seen by both cameras, carry its grid point to where
it is: it takes 8 from its first frame. A spot half way between where 8 and 13 (both
covered) have been carried waits, and marker 7, lost and back in the side 5 mm from where 8
was carried, is not given 8.

Scenes are 3D points projected through the twin's true cameras, so each detection's marker is
known.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from projected import GRID15, numbers_given, run_scene

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.stereo import StereoTrackConfig

FLOW = np.array([0.0, 0.0, 0.004])  # the bed's flow along Z [m/frame]
OUT_AT = 6  # the frame marker 8 comes out in the side camera
FRAMES = 12


def _run(rig, coming_out: bool, shift: np.ndarray, back: int = 8,
         debris: np.ndarray | None = None) -> list:
    """Released frames of a pass on GRID15 flowing along Z: 8 and 13 covered in both cameras
    (and marker ``back`` too, from frame 1, when it is not 8); from ``OUT_AT`` the side sees
    marker ``back`` ``shift`` off where the bed carried marker 8; with ``debris`` (3,) m, a
    still spot there that only the side sees, from the start."""
    config = replace(StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)), coming_out=coming_out)

    def frame(k: int) -> tuple[list, list]:
        pts = np.array(GRID15) + k * FLOW
        gone = {8, 13, back} if k >= 1 else {8, 13}
        front = [p for m, p in enumerate(pts, 1) if m not in gone]
        side = front + ([pts[7] + shift] if k >= OUT_AT else []) \
            + ([debris] if debris is not None else [])
        return side, front

    return run_scene(rig, config, map(frame, range(FRAMES)))[0]


def _side_numbers_of_eight(rig, out: list, shift: np.ndarray) -> list[int]:
    """The number the side gave marker 8's spot in each frame from ``OUT_AT``."""
    return numbers_given(out, rig.cameras[0],
                         lambda k: np.array(GRID15[7]) + k * FLOW + shift, OUT_AT)


def test_the_spot_is_far_from_its_grid_point(rig) -> None:
    """Precondition: at its first frame marker 8 is beyond the grid gate of its grid point."""
    side = rig.cameras[0]
    uv = side.project(np.array([GRID15[7], np.array(GRID15[7]) + OUT_AT * FLOW]))
    assert np.linalg.norm(uv[1] - uv[0]) > 1.5 * StereoTrackConfig().grid_gate_px


@pytest.mark.parametrize('coming_out', [False, True])
def test_a_marker_out_of_the_sand_in_one_camera_takes_its_carried_number(
        rig, coming_out: bool) -> None:
    """Numbered 8 from its first frame with the rule, never without it; no number twice."""
    out = _run(rig, coming_out, np.zeros(3))
    got = _side_numbers_of_eight(rig, out, np.zeros(3))
    assert set(got) == ({8} if coming_out else {-1})
    for f in out:
        assert len(set(f.markers[f.markers >= 0].tolist())) == int((f.markers >= 0).sum())


def test_a_spot_between_two_covered_markers_waits(rig) -> None:
    """Half way between where 8 and 13 were carried (13 is 25 mm along X): no number."""
    shift = np.array([0.0125, 0.0, 0.0])
    assert set(_side_numbers_of_eight(rig, _run(rig, True, shift), shift)) == {-1}


def test_a_lost_marker_back_near_a_covered_ones_place_is_not_given_its_number(rig) -> None:
    """Marker 7, covered in both cameras since frame 1 (its track expired), comes back in the
    side at frame 6 pushed 20 mm ahead of the bed, 5 mm from where 8 (covered) was carried:
    7 could have got there from its last sighting, so the spot is not given 8."""
    shift = np.array([0.0, 0.0, -0.005])
    assert 8 not in _side_numbers_of_eight(rig, _run(rig, True, shift, back=7), shift)


def test_a_spot_touching_another_waits(rig) -> None:
    """A still spot the side alone sees (a clod, a stone) 6 mm beside where 8 comes out,
    under a marker's diameter in the side view: two touching spots, whose tracks the 2D link
    may swap, so the new spot waits."""
    shift = np.zeros(3)
    debris = np.array(GRID15[7]) + OUT_AT * FLOW + np.array([0.006, 0.0, 0.0])
    side = rig.cameras[0]
    gap = np.linalg.norm(side.project(debris[None]) - side.project(
        (np.array(GRID15[7]) + OUT_AT * FLOW)[None]))
    assert gap < 8, f'precondition: the clod is {gap:.1f} px from 8 in the side view'
    assert set(_side_numbers_of_eight(rig, _run(rig, True, shift, debris=debris), shift)) \
        == {-1}
