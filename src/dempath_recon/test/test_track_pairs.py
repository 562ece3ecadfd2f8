"""A track left unnumbered decided again over time (``tracking.track_pairs``): the grid fit
refuses a front spot with a second marker hidden behind it both numbers; once the hidden
marker has moved off the spot's line in the side camera, the spot's pair with the side's
track of its own marker, held on the epipolar line over several frames and nearest the front
camera, numbers it, and the frames still held by the publication delay go out numbered.

Scenes are 3D points projected through the twin's true cameras, so each detection's marker
is known.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from projected import GRID15, feed_frame, numbers_given

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.linker import TrackerConfig
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

DT = 0.02  # frame period [s]
OFFSET = 0.003  # the front camera exposes this much after the side one [s]
GRID6 = tuple((x, 0.0, z) for z in (-0.05, 0.05) for x in (-0.05, 0.0, 0.05))  # markers 1-6
STEP = np.array([0.0, 0.0, 0.005])  # the flow: 5 mm a frame along Z
FRAMES = 16


def _centre(cam) -> np.ndarray:
    """(3,) camera centre in the world frame [m]."""
    return -np.asarray(cam.R).T @ np.asarray(cam.t)


def _dets(cam, xyz: np.ndarray) -> Detections:
    """Exact detections of the points (k, 3) m in one camera."""
    uv = cam.project(np.asarray(xyz, np.float64).reshape(-1, 3))
    return Detections(uv, np.ones(len(uv)), np.full(len(uv), 4.0))


def _hidden_scene(rig, drift_m: float) -> tuple[list, np.ndarray]:
    """Markers 1-6 on ``GRID6`` flowing along Z, and marker 7 25 mm behind marker 2 on the
    front camera's line of sight, flowing too and drifting ``drift_m`` a frame along X. The
    front never sees 7 (behind 2 at first, covered after); the side sees all seven. Returns
    (side points, front points) per frame, and 7's start."""
    two = np.array(GRID6[1])
    ray = two - _centre(rig.cameras[1])
    seven = two + 0.025 * ray / np.linalg.norm(ray)
    scene = []
    for k in range(FRAMES):
        pts = [np.array(g) + k * STEP for g in GRID6]
        hidden = seven + k * (STEP + np.array([drift_m, 0.0, 0.0]))
        scene.append(([*pts, hidden], pts))
    return scene, seven


def _run(rig, scene: list, seven: np.ndarray) -> tuple[list, StereoMarkerTracker]:
    """The frames as released (publication delay 5 frames), and the tracker."""
    cams = {c.name: c for c in rig.cameras}
    config = StereoTrackConfig(grid=MarkerGrid(layout_m=(*GRID6, tuple(seven))),
                               tracker=TrackerConfig(max_lost_s=0.1), number_delay_frames=5)
    tracker = StereoMarkerTracker(cams, config)
    out = []
    for k, (side_pts, front_pts) in enumerate(scene):
        tracker.update_detections('cam_side', k * DT, _dets(cams['cam_side'],
                                                            np.array(side_pts)))
        out += tracker.release()
        tracker.update_detections('cam_front', k * DT + OFFSET,
                                  _dets(cams['cam_front'], np.array(front_pts)))
        out += tracker.release()
    return out + tracker.flush(), tracker


def _front_numbers_of_two(rig, out: list) -> list[int]:
    """The number the front gave marker 2's spot in each of its frames."""
    front = rig.cameras[1]
    fronts = sorted((f for f in out if f.camera == 'cam_front'), key=lambda f: f.stamp_s)
    got = []
    for k, f in enumerate(fronts):
        uv = front.project((np.array(GRID6[1]) + k * STEP)[None])[0]
        got.append(int(f.markers[int(np.argmin(np.linalg.norm(f.uv - uv, axis=1)))]))
    return got


def test_spot_refused_at_the_fit_is_numbered_once_the_marker_behind_moves_off(rig) -> None:
    """Marker 7 behind 2 in the front at the fit: the front's spot is refused 2 and 7. 7
    drifts 4 mm a frame sideways, off the spot's line in the side: the spot is numbered 2
    (never 7) in every frame: decided at the fourth frame, the first three go out numbered
    too (held by the publication delay); 1-6 keep their numbers."""
    scene, seven = _hidden_scene(rig, 0.004)
    out, tracker = _run(rig, scene, seven)
    got = _front_numbers_of_two(rig, out)
    assert got == [2] * FRAMES, got
    assert tracker.report()['cam_front']['numbered_by_track_pair'] == 1
    fronts = [f for f in out if f.camera == 'cam_front']
    assert all(set(f.markers.tolist()) - {-1} <= {1, 2, 3, 4, 5, 6} for f in fronts)


def test_spot_waits_while_the_marker_behind_stays_on_its_line(rig) -> None:
    """The same, 7 staying behind 2 (no drift): the spot may be 7's as much as 2's (7 may
    show beside 2 and pull the centre between): it stays unnumbered."""
    scene, seven = _hidden_scene(rig, 0.0)
    out, tracker = _run(rig, scene, seven)
    assert set(_front_numbers_of_two(rig, out)) == {-1}
    assert tracker.report()['cam_front']['numbered_by_track_pair'] == 0


def _side_hidden_scene(rig) -> tuple[list, np.ndarray]:
    """Markers 1-6 flowing along Z, and marker 7 25 mm behind marker 2 on the side camera's
    line of sight, flowing with them: the side sees 2 only there, the front sees both."""
    two = np.array(GRID6[1])
    ray = two - _centre(rig.cameras[0])
    seven = two + 0.025 * ray / np.linalg.norm(ray)
    scene = []
    for k in range(8):
        pts = [np.array(g) + k * STEP for g in GRID6]
        scene.append((pts, [*pts, seven + k * STEP]))
    return scene, seven


def test_a_pair_is_what_the_partner_sees_only_if_nearest_the_partners_camera(rig) -> None:
    """The side's spot of marker 2 hides 7 behind it: both front spots (2's and 7's) hold on
    its epipolar line. The front's spot of 7 paired with it would make the side's spot 7, but
    the side sees what lies nearest it, 2 (``_seen_by_partner`` says no for the front's 7,
    yes for the front's 2)."""
    from dempath_recon.tracking.track_pairs import _seen_by_partner

    scene, seven = _side_hidden_scene(rig)
    _, tracker = _run(rig, scene, seven)
    state = tracker.state
    side, front = rig.cameras
    last = len(scene) - 1

    def track_at(cam, xyz):
        uv = cam.project(xyz[None])[0]
        return min((t for t in state.trackers[cam.name].tracks),
                   key=lambda t: float(np.linalg.norm(t.uv - uv)))

    spot = track_at(side, np.array(GRID6[1]) + last * STEP)
    front_two = track_at(front, np.array(GRID6[1]) + last * STEP)
    front_seven = track_at(front, seven + last * STEP)
    stamp = last * DT + OFFSET
    assert _seen_by_partner(state, 'cam_front', front_two, spot, stamp)
    assert not _seen_by_partner(state, 'cam_front', front_seven, spot, stamp)


def test_a_pair_waits_on_the_line_of_a_marker_the_other_camera_saw_hidden(rig) -> None:
    """``pair_numbering._on_own_lines``: a side spot on the front's line of marker 7, which the
    side saw hidden behind 2 at the grid fit and holds on no track, may be 7 out from behind;
    a side spot off that line, or on the line of a marker the side never saw hidden, is
    free to pair."""
    from dempath_recon.tracking.pair_numbering import _on_own_lines

    scene, seven = _side_hidden_scene(rig)
    _, tracker = _run(rig, scene, seven)
    state = tracker.state
    side, front = rig.cameras
    assert any(7 in ms for ms in state.fit_merged['cam_side'].values())
    seven_now = seven + (len(scene) - 1) * STEP
    uv_front = front.project(np.array([seven_now, np.array(GRID6[3])]))
    on_line = side.project(seven_now[None])  # 7 itself, seen in the side at last
    off_line = side.project((seven_now + np.array([0.0, 0.03, 0.0]))[None])
    uv_o = np.vstack([on_line, off_line])
    got = _on_own_lines(state, 'cam_front', np.array([7, -1], np.int32), uv_front, uv_o)
    assert got.tolist() == [True, False]
    got = _on_own_lines(state, 'cam_front', np.array([4, -1], np.int32), uv_front[::-1], uv_o)
    assert got.tolist() == [False, False]


def test_a_pair_holds_on_the_line_by_the_look_s_own_residuals(rig) -> None:
    """``held_line.held_on_line``: with numbered pairs at 0.5 px from their lines, a pair at
    2-2.5 px in every frame (inside the 4 px of one frame's numbering) did not hold; one at
    0.2-0.5 px did, and so does one at 2-2.5 px where the numbered pairs lie at 1.2 px (a
    noisier look); any frame beyond 4 px breaks it."""
    from dempath_recon.tracking.held_line import held_on_line
    from dempath_recon.tracking.state import StereoState

    state = StereoState.start({c.name: c for c in rig.cameras}, StereoTrackConfig())
    wide, tight = np.array([2.0, 2.5, 2.0, 2.2]), np.array([0.3, 0.5, 0.2, 0.4])
    state.residuals['cam_side'] = [0.5] * 10
    assert held_on_line(state, tight) and not held_on_line(state, wide)
    state.residuals['cam_side'] = [1.2] * 10
    assert held_on_line(state, wide)
    assert not held_on_line(state, np.array([0.3, 0.5, 4.5, 0.4]))


def test_a_spot_waits_while_a_marker_neither_camera_holds_is_carried_beside_it(rig) -> None:
    """``track_pairs._missing_beside``: marker 7, in the grid 25 mm behind 2 on the front's
    line of sight and found by neither camera, is carried by the bed (with 1-6) to 2's spot
    in the front: 2's spot may hold 7 too. Marker 4's spot has no such neighbour; and a
    marker this camera holds elsewhere does not count."""
    from dempath_recon.tracking.track_pairs import _missing_beside

    two = np.array(GRID6[1])
    ray = two - _centre(rig.cameras[1])
    seven = two + 0.025 * ray / np.linalg.norm(ray)
    scene = [([np.array(g) + k * STEP for g in GRID6],) * 2 for k in range(6)]
    _, tracker = _run(rig, scene, seven)
    front = rig.cameras[1]
    last = len(scene) - 1
    stamp = last * DT + OFFSET
    at_two, at_four = front.project(np.array([two, GRID6[3]]) + last * STEP)
    held = {1, 2, 3, 4, 5, 6}
    assert _missing_beside(tracker.state, 'cam_front', 2, at_two, stamp, held)
    assert not _missing_beside(tracker.state, 'cam_front', 4, at_four, stamp, held)
    assert not _missing_beside(tracker.state, 'cam_front', 2, at_two, stamp, held | {7})


FLOW = np.array([0.0, 0.0, 0.001])  # the bed's slow flow along Z [m/frame]
PUSH = np.array([0.0, 0.0, 0.003])  # the tool pushes markers 8 and 9 this much more [m/frame]
SIDE_FROM = 4  # the frame the side camera first sees marker 8


def _pushed_run(rig, numbered_partner: bool = True, intruder: bool = False) -> list:
    """Released frames of a pass on GRID15: the tool pushes markers 8 and 9 ahead of the bed,
    so where the bed carried them (their grid points moved with their neighbours) falls behind
    them, 8 ending 4 mm from 9's carried point; the front sees every marker, the side never 9
    nor 8 before ``SIDE_FROM``. With ``intruder``, a spot the front alone sees lies on the side
    8's line of sight 40 mm nearer the side camera from frame 6 (a young front track that may
    hide 8 from the side). ``numbered_partner``: ``StereoTrackConfig.numbered_partner``."""
    cams = {c.name: c for c in rig.cameras}
    config = StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15), number_delay_frames=5,
                               numbered_partner=numbered_partner,
                               whole_pass=False)  # the frame rule alone (the pass numbers 8 too)
    tracker = StereoMarkerTracker(cams, config)
    side_c = _centre(cams['cam_side'])
    out = []
    for k in range(FRAMES):
        pts = np.array(GRID15) + k * FLOW
        pts[7:9] += k * PUSH
        side = [p for m, p in enumerate(pts, 1) if m != 9 and (m != 8 or k >= SIDE_FROM)]
        front = list(pts)
        if intruder and k >= 6:
            ray = side_c - pts[7]
            front.append(pts[7] + 0.04 * ray / np.linalg.norm(ray))
        out += feed_frame(tracker, cams, k, side, front)
    return out + tracker.flush()


def _side_numbers_of_eight(rig, out: list) -> list[int]:
    """The number the side gave marker 8's spot in each frame from ``SIDE_FROM``."""
    return numbers_given(out, rig.cameras[0],
                         lambda k: np.array(GRID15[7]) + k * (FLOW + PUSH), SIDE_FROM)


@pytest.mark.parametrize('numbered_partner', [False, True])
def test_a_numbered_partner_names_a_pair_the_bed_did_not_carry_there(
        rig, numbered_partner: bool) -> None:
    """Side marker 8, never triangulated, out at frame 4 on the line of the front's 8: its
    carried point lags 12-25 mm behind and 9's (hidden in the side, seen by the front on its
    own spot) is nearer. With the other camera's number counted (9 is not a rival, 30 mm
    gate) it is numbered 8; with the carried-point test alone (every free marker a rival,
    15 mm) it waits."""
    got = _side_numbers_of_eight(rig, _pushed_run(rig, numbered_partner))
    if not numbered_partner:
        assert set(got) == {-1}
        return
    assert got[-4:] == [8] * 4 and set(got) <= {8, -1}


def test_a_young_track_on_the_line_nearer_this_camera_keeps_the_pair_waiting(rig) -> None:
    """A front-only spot on the side 8's line 40 mm nearer the side camera from frame 6: the
    side cannot tell which of the two it sees, so 8 is never given."""
    got = _side_numbers_of_eight(rig, _pushed_run(rig, intruder=True))
    assert 8 in _side_numbers_of_eight(rig, _pushed_run(rig))  # numbered without the spot
    assert 8 not in got
