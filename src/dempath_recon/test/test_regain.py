"""A number elimination took back for a jump, given back once both cameras pair the track
(``tracking.regain``): marker 8, moved by the bed before the first frame so the side's grid fit
leaves it unnumbered and hidden from the front, is numbered 8 by elimination; at frame 3 the
tine shoves it 7 mm (a step far off its prediction: elimination takes 8 back), and at
frame 5 it comes out in the front too. Without the rule both cameras leave it unnumbered for
the rest of the pass; with it both give it out as 8. Where the kick is a neighbour's spot
instead (the track takes marker 9's place while 8 goes under), the pair is 9, carried nearer,
and 8 is not given back (tested on the carried places themselves).

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
from dempath_recon.tracking.regain import REGAIN_GATE_M, _carried_there
from dempath_recon.tracking.state import carried_point
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

FLOW = np.array([0.0, 0.0005, 0.001])  # the bed's slow heave [m/frame]
MOVED = np.array([0.0, 0.007, 0.007])  # marker 8 before the first frame [m]
PUSH = np.array([0.0, 0.0, 0.007])  # marker 8's own step when the tine pushes it [m]
PUSHED_AT = 3  # the frame it is pushed in
FRONT_FROM = 5  # first frame the front camera sees it
FRAMES = 14


def _eight(k: int) -> np.ndarray:
    """Marker 8 at frame ``k`` [m]."""
    return np.array(GRID15[7]) + MOVED + k * FLOW + (k >= PUSHED_AT) * PUSH


def _run(rig, regain: bool) -> list:
    """Released frames of the pass (module docstring), ``StereoTrackConfig.regain`` as given
    (the whole pass's piece numbering off: with regain off it numbers the pushed 8 from its
    path, which is not this rule's doing)."""
    config = replace(StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)), regain=regain,
                     piece_numbering=False)

    def frame(k: int) -> tuple[list, list]:
        pts = np.array(GRID15) + k * FLOW
        pts[7] = _eight(k)
        return list(pts), [p for m, p in enumerate(pts, 1) if m != 8 or k >= FRONT_FROM]

    out, tracker = run_scene(rig, config, map(frame, range(FRAMES)))
    assert tracker.state.counts['cam_side'].numbered_by_elimination == 1  # the scene's premise
    return out


@pytest.mark.parametrize('regain', [False, True])
def test_a_pushed_marker_gets_its_number_back_once_both_cameras_see_it(rig, regain: bool,
                                                                         ) -> None:
    """Without the rule 8 stays unnumbered in both cameras after the push; with it, both give
    it out as 8 from the frame the front found it, and no frame gives a number twice."""
    out = _run(rig, regain)
    side = numbers_given(out, rig.cameras[0], _eight, FRONT_FROM)
    front = numbers_given(out, rig.cameras[1], _eight, FRONT_FROM)
    if not regain:
        assert set(side) == {-1} and set(front) == {-1}
        return
    assert set(side) == {8} and set(front) == {8}
    for f in out:
        assert len(set(f.markers[f.markers >= 0].tolist())) == int((f.markers >= 0).sum())



def test_a_pair_where_the_bed_carried_a_neighbour_is_not_given_the_number(rig) -> None:
    """Had the track taken a neighbour's spot (9, nobody holding it), the pair would lie where
    the bed carried 9, a pitch from 8's carried place (inside the 30 mm gate): 8 is not given
    (it fails with ``REGAIN_RATIO`` at 0); at 8's own place it is."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)))
    for k in range(4):  # 8 and 9 hidden from the front, 9 from the side: neither is held
        pts = np.array(GRID15) + k * FLOW
        feed_frame(tracker, cams, k, [p for m, p in enumerate(pts, 1) if m != 9],
                   [p for m, p in enumerate(pts, 1) if m not in (8, 9)])
    state, stamp = tracker.state, 3 * DT
    held = {t.marker for c in state.cameras for t in state.trackers[c].tracks
            if t.marker >= 0 and not t.lost and t.marker != 8}
    assert 9 not in held
    at = {m: carried_point(state, m, stamp)[0] for m in (8, 9)}
    assert np.linalg.norm(at[9] - at[8]) < REGAIN_GATE_M
    assert _carried_there(state, 8, at[8], stamp, held)
    assert not _carried_there(state, 8, at[9], stamp, held)
