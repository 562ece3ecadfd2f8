"""The frame-to-frame linker's choices when a covered marker's track could take a running
track's spot, and a track's refused numbers after it jumped to another marker's spot.

Synthetic cases, exact positions: each detection's true marker is known.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.linker import (
    MarkerTracker,
    TrackerConfig,
    held_links,
    hold_radii,
    rival_tracks,
)
from dempath_recon.tracking.stereo import StereoTrackConfig

sys.path.insert(0, str(Path(__file__).parent))
from test_association import GRID, intruder, numbers_at, run

DT = 0.02  # frame period [s]


def dets(uv: np.ndarray) -> Detections:
    """Detections at exact positions (px)."""
    return Detections(np.asarray(uv, np.float64).reshape(-1, 2), np.ones(len(uv)),
                      np.full(len(uv), 3.0))


def test_running_track_is_not_pushed_onto_a_neighbour_to_make_room_for_a_lost_one() -> None:
    """Marker 1 moves 2 px a frame; marker 2, 33 px beside its path, is covered from frame 3;
    at frame 5 an unknown marker appears 14 px from marker 1, beyond the reach of 2's lost
    track. Linking 1 to the newcomer and re-attaching 2 onto 1's spot would make one more
    link, at 48 px of misses instead of 0: marker 1 keeps its spot, the newcomer is a new
    track, and 2 stays lost."""
    tracker = MarkerTracker()
    start = np.array([[100.0, 100.0], [110.0, 133.0]])
    tracker.seed(start, np.array([1, 2], np.int32), -DT)
    frames = []
    for k in range(8):
        uv = [start[0] + [2.0 * (k + 1), 0.0]]
        if k < 3:
            uv.append(start[1])
        if k >= 5:
            uv.append(start[0] + [2.0 * (k + 1), -14.0])  # the newcomer, 14 px from marker 1
        frames.append((uv, tracker.update(k * DT, dets(np.array(uv)))))
    reach = np.linalg.norm(frames[5][0][1] - start[1])
    assert reach > tracker.config.reattach_px, f'precondition: newcomer {reach:.0f} px from 2'
    assert np.linalg.norm(frames[5][0][0] - start[1]) < tracker.config.reattach_px
    for uv, frame in frames[5:]:
        got = {tuple(p): int(m) for p, m in zip(frame.uv, frame.markers, strict=True)}
        assert got[tuple(uv[0])] == 1 and got[tuple(uv[1])] == -1
        assert not any('re-attached' in e for e in frame.events)
    assert tracker.counts.reattached == 0 and tracker.counts.new_tracks == 1


def test_lost_track_still_takes_a_spot_it_predicts_better() -> None:
    """Marker 1's own spot gone (covered) and marker 2 back 3 px from where it was lost,
    16 px from marker 1's prediction: the spot is 2's (re-attached), 1 is lost."""
    tracker = MarkerTracker()
    tracker.seed(np.array([[100.0, 100.0], [100.0, 120.0]]), np.array([1, 2], np.int32), -DT)
    tracker.update(0.0, dets(np.array([[100.0, 100.0], [100.0, 120.0]])))
    tracker.update(DT, dets(np.array([[100.0, 100.0]])))
    frame = tracker.update(2 * DT, dets(np.array([[100.0, 117.0]])))
    assert list(frame.markers) == [2]
    assert any('re-attached track 1 (marker 2)' in e for e in frame.events)
    assert any('lost track 0 (marker 1)' in e for e in frame.events)


def test_refused_number_is_forgotten_when_the_track_jumps_to_another_spot(rig) -> None:
    """Marker 3 covered in the front; a front-only spot x on 3's epipolar line 80 mm nearer
    starts a track, which is refused number 3 (an impossible depth). x is then covered, and
    marker 3, which moved 60 mm towards the side camera meanwhile (the side still sees it),
    reappears in the front nearer x's last spot than its own: the track of x re-attaches
    there, more than ``doubt_link_px`` from its prediction, so it may be another marker now
    and the refusal, made on x's spot, no longer applies: the spot is numbered 3 from the
    side camera's line."""
    p1, p2, p3 = (np.array(g) for g in GRID)
    x = intruder(rig, p3, 0.08)
    moved = intruder(rig, p3, 0.06)  # on the side's line of sight: the side sees no move
    front = rig.cameras[1]
    jump = np.linalg.norm(front.project(moved[None]) - front.project(x[None]))
    own = np.linalg.norm(front.project(moved[None]) - front.project(p3[None]))
    assert 5 < jump < own, f'precondition: {jump:.0f} px from x, {own:.0f} px from 3'
    scene = [([p1, p2, p3], [p1, p2, p3])] * 3 + [([p1, p2, p3], [p1, p2, x])]
    scene += [([p1, p2, moved], [p1, p2])] + [([p1, p2, moved], [p1, p2, moved])] * 3
    out, tracker = run(rig, scene, StereoTrackConfig(grid=MarkerGrid(layout_m=GRID)))
    fronts = [f for f in out if f.camera == 'cam_front']
    assert numbers_at(fronts[3], front, x) == -1
    assert any('is not marker 3' in e for e in fronts[3].events)
    assert [numbers_at(f, front, moved) for f in fronts[5:]] == [3, 3, 3]
    assert tracker.report()['cam_front']['numbered_by_epipolar'] == 1


def test_a_covered_marker_track_does_not_push_its_neighbours_along() -> None:
    """Markers 10, 9 and 8 lie in a row (a clod the tool lifts); 10 is covered. Its track, still
    running, could take 9's spot 11.3 px off if 9's track took 8's (9 px off) and 8's a newcomer
    22.6 px off: one more link for 41 px of moves, worth it to the assignment alone. Each
    running track keeps the spot it predicts within 2 px; 10 is lost, the newcomer is new."""
    tracker = MarkerTracker()
    tracker.seed(np.array([[0.0, 0.0], [13.1, 0.0], [23.8, 0.0]]),
                 np.array([10, 9, 8], np.int32), -DT)
    uv = np.array([[11.3, 0.0], [22.1, 0.0], [46.4, 0.0]])  # 9's, 8's spot, a newcomer
    frame = tracker.update(0.0, dets(uv))
    got = {tuple(p): int(m) for p, m in zip(frame.uv, frame.markers, strict=True)}
    assert got == {(11.3, 0.0): 9, (22.1, 0.0): 8, (46.4, 0.0): -1}, got
    assert any('lost track 0 (marker 10)' in e for e in frame.events)


def test_held_links_need_each_other_nearest_and_a_running_track() -> None:
    """A detection two running tracks both predict within the radius is held for the nearer
    only; a lost track's nearest spot is not held (its re-attachment is the assignment's)."""
    cost = np.array([[0.5, 9.0], [1.5, 8.0], [9.0, 0.4]])
    assert held_links(cost, np.array([True, True, True]), 2.0) == [(0, 0), (2, 1)]
    assert held_links(cost, np.array([True, True, False]), 2.0) == [(0, 0)]
    assert held_links(cost, np.array([True, True, True]), 0.0) == []


def test_a_spot_another_track_predicts_as_well_is_held_for_none() -> None:
    """Two fast markers crossing (a rendered pass with the tool at 1 m/s): marker 3's running
    track predicts marker 8's spot (detection 1) 1.6 px off, 8's track, lost a frame before,
    5.7 px off; 3's own spot (detection 0) lies 6.0 px from 3's prediction, 12.4 px from 8's.
    Within a marker's image diameter (8 px) of the rival's prediction the spot is held for
    neither, and the assignment then gives each its own spot; without the rival test (0) the
    spot is held for 3, which left 8 only 3's spot."""
    cost = np.array([[6.0, 1.6], [12.4, 5.7]])
    running = np.array([True, False])
    assert held_links(cost, running, 2.0) == [(0, 1)]
    assert held_links(cost, running, 2.0, 8.0) == []
    assert held_links(cost, running, 2.0, 5.0) == [(0, 1)]  # the rival beyond the distance
    assert crossing(8.0) == {(935.3, 521.2): 3, (939.3, 527.3): 8}
    assert crossing(0.0) == {(935.3, 521.2): 8, (939.3, 527.3): 3}  # the rule off: swapped


def crossing(rival_px: float) -> dict[tuple[float, float], int]:
    """The crossing above on a real linker: marker 3 running at (-232, -76) px/s, marker 8 lost
    a frame before at (-128, -135) px/s; the numbers its two spots get."""
    return two_tracks(TrackerConfig(hold_rival_px=rival_px),
                      (((944.4, 527.3), 3, (-232.0, -76.0), -DT, False),
                       ((947.1, 536.5), 8, (-128.0, -135.0), -2 * DT, True)),
                      [[935.3, 521.2], [939.3, 527.3]])


Seed = tuple[tuple[float, float], int, tuple[float, float], float, bool]


def two_tracks(config: TrackerConfig, seeds: tuple[Seed, ...],
               uv: list[list[float]]) -> dict[tuple[float, float], int]:
    """A real linker started with tracks (position px, marker, velocity px/s, last seen s,
    lost), given one frame of detections ``uv`` at 0 s: the number each detection gets."""
    tracker = MarkerTracker(config)
    for at, marker, velocity, seen, lost in seeds:
        tracker.seed(np.array([at]), np.array([marker], np.int32), seen)
        tracker.tracks[-1].velocity = np.array(velocity)
        tracker.tracks[-1].lost = lost
    frame = tracker.update(0.0, dets(np.array(uv)))
    return {(float(p[0]), float(p[1])): int(m)
            for p, m in zip(frame.uv, frame.markers, strict=True)}


def test_hold_radius_is_checked() -> None:
    """A negative hold radius, or one as wide as the gate, is one clear error."""
    for bad in (-1.0, 25.0):
        try:
            TrackerConfig(hold_px=bad)
        except ValueError as err:
            assert 'hold_px' in str(err)
        else:
            raise AssertionError(f'hold_px={bad} accepted')


def test_a_fast_track_keeps_its_spot_from_a_track_unseen_for_long() -> None:
    """The tool at twice its speed (a tuning render of hidden seed 111, the side camera): marker
    7's running track moves 12 px a frame and predicts its spot 2.1 px off, marker 3 comes out
    of the sand 8.3 px from that prediction, and 3's track, unseen for three frame periods,
    predicts 7's spot 7.7 px off (inside a marker's width, 8.4 px). Nothing held, the
    assignment's swap (3 onto 7, 7 onto 3) is worth 0.1 px more than the right links. With the
    hold grown to a quarter of 7's step and 3's track no rival, 7 keeps its spot; each half of
    the rule alone, or neither, leaves the swap when the spots are given by summed link
    lengths (``lost_spread_px`` 0). In expected misses (3's track, lost 0.06 s, expects 7 px)
    the right links win without the hold too."""
    right = {(937.2, 518.6): 3, (941.2, 526.0): 7}
    assert fast_and_unseen(TrackerConfig(hold_rival_px=8.4, lost_spread_px=0.0)) == right
    swapped = {(937.2, 518.6): 7, (941.2, 526.0): 3}
    for off in ({'hold_step_share': 0.0}, {'hold_rival_unseen_s': 0.0},
                {'hold_step_share': 0.0, 'hold_rival_unseen_s': 0.0}):
        assert fast_and_unseen(TrackerConfig(hold_rival_px=8.4, lost_spread_px=0.0,
                                             **off)) == swapped, off
        assert fast_and_unseen(TrackerConfig(hold_rival_px=8.4, **off)) == right, off


def fast_and_unseen(config: TrackerConfig) -> dict[tuple[float, float], int]:
    """The case above on a real linker: the numbers its two spots get."""
    return two_tracks(config, (((952.9, 526.5), 3, (-80.0, -4.0), -3 * DT, True),
                               ((953.7, 530.3), 7, (-545.0, -280.0), -DT, False)),
                      [[937.2, 518.6], [941.2, 526.0]])


def test_hold_radius_grows_with_the_step_and_old_tracks_rival_only_slow_holds() -> None:
    """A track moving 600 px/s holds within a quarter of its 12 px step, a slow one within
    ``hold_px``; nothing is held when ``hold_px`` is 0. A track seen 0.06 s ago rivals no fast
    track's hold, but a slow track's still; one seen 0.04 s ago rivals both; with the time 0
    every track rivals every hold."""
    tracker = MarkerTracker()
    tracker.seed(np.array([[0.0, 0.0], [50.0, 0.0]]), np.array([1, 2], np.int32), -DT)
    tracker.tracks[0].velocity = np.array([600.0, 0.0])
    tracker.tracks[1].velocity = np.array([50.0, 0.0])
    assert np.allclose(hold_radii(tracker.tracks, 0.0, tracker.config), [3.0, 2.0])
    assert np.allclose(hold_radii(tracker.tracks, 0.0, TrackerConfig(hold_px=0.0)), [0.0, 0.0])
    assert np.allclose(hold_radii(tracker.tracks, 0.0, TrackerConfig(hold_step_share=0.0)),
                       [2.0, 2.0])
    fast = np.array([True, False])
    tracker.tracks[1].last_stamp_s = -0.06
    assert rival_tracks(tracker.tracks, 0.0, 0.05, fast).tolist() == [[True, False],
                                                                      [True, True]]
    tracker.tracks[1].last_stamp_s = -0.04
    assert rival_tracks(tracker.tracks, 0.0, 0.05, fast).all()
    tracker.tracks[1].last_stamp_s = -1.0
    assert rival_tracks(tracker.tracks, 0.0, 0.0, fast).all()
    cost = np.array([[2.5, 9.0], [7.0, 8.0]])
    running = np.array([True, False])
    assert held_links(cost, running, np.array([3.0, 2.0])) == [(0, 0)]
    assert held_links(cost, running, np.array([3.0, 2.0]), 8.0) == []
    assert held_links(cost, running, np.array([3.0, 2.0]), 8.0,
                      np.array([[True, False], [True, True]])) == [(0, 0)]


def test_a_slow_track_still_gives_way_to_a_marker_back_where_it_sank() -> None:
    """A cohesive dusk render (hidden seed 129, the front camera): marker 3 sank beside marker 4
    and comes out 2.8 px from where its track, unseen for 0.2 s, predicts it; 4's slow track
    (2 px a frame) predicts 3's spot 1.4 px off and its own 3.2 px off. The unseen track still
    rivals a slow hold, so nothing is held and each keeps its own spot; were it no rival, 4's
    track would be held on 3's spot."""
    config = TrackerConfig(hold_rival_px=8.0)
    got = two_tracks(config, (((929.5, 552.2), 3, (-4.0, -2.0), -10 * DT, True),
                              ((931.8, 553.9), 4, (60.0, -85.0), -DT, False)),
                     [[935.9, 550.8], [931.7, 552.8]])
    assert got == {(935.9, 550.8): 4, (931.7, 552.8): 3}


def test_hold_step_and_rival_time_are_checked() -> None:
    """A hold share outside [0, 1) or a negative rival time is one clear error naming it."""
    for name, bad in (('hold_step_share', -0.1), ('hold_step_share', 1.0),
                      ('hold_rival_unseen_s', -0.01)):
        try:
            TrackerConfig(**{name: bad})
        except ValueError as err:
            assert name in str(err)
        else:
            raise AssertionError(f'{name}={bad} accepted')
