"""Who takes which spot when a lost track and a running one both link: each track's miss in
units of its expected miss (``TrackerConfig.lost_spread_px``, ``MarkerTracker._reassign``).

Synthetic cases, exact positions: each detection's true marker is known. The first is the
side camera of heldout21's carriage look (released for tuning), its pixels as traced there.
"""

from __future__ import annotations

import numpy as np

from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.linker import MarkerTracker, TrackerConfig

DT = 0.02  # frame period [s]
RIVAL_PX = 6.4  # the side camera's hold rival distance on that look (a marker's image diameter)
STILL = np.array([971.1, 528.8])  # marker 2 stands here, then sinks for 0.1 s
RUNNER_AT_8 = np.array([966.0, 527.5])  # where marker 1's track predicts it in frame 8 [px]
STEP = np.array([-3.1, 0.0])  # marker 1's step a frame [px]
RUNNER_SPOT = RUNNER_AT_8 + np.array([1.5, -0.7])  # frame 8: 1.7 px from 1's prediction,
# 4.1 px from 2's
STILL_SPOT = RUNNER_AT_8 + np.array([-4.7, 1.6])  # 2 comes out 9.9 px from where it sank,
# 5.0 px from 1's prediction


def dets(uv: np.ndarray) -> Detections:
    """Detections at exact positions (px)."""
    return Detections(np.asarray(uv, np.float64).reshape(-1, 2), np.ones(len(uv)),
                      np.full(len(uv), 3.0))


def run_crossing(lost_spread_px: float) -> dict[tuple[float, float], int]:
    """Marker 1 runs 3.1 px a frame past marker 2, which stands still, sinks after frame 3
    and comes out in frame 8 carried 9.9 px along 1's path; the marker number each spot of
    frame 8 is linked to."""
    tracker = MarkerTracker(TrackerConfig(hold_rival_px=RIVAL_PX, lost_spread_px=lost_spread_px))
    runner = [RUNNER_AT_8 - STEP * (8 - k) for k in range(8)]
    tracker.seed(np.array([runner[0] - STEP, STILL]), np.array([1, 2], np.int32), -DT)
    for k in range(8):
        tracker.update(k * DT, dets(np.array([runner[k], STILL] if k <= 3 else [runner[k]])))
    frame = tracker.update(8 * DT, dets(np.array([RUNNER_SPOT, STILL_SPOT])))
    return {(round(float(p[0]), 1), round(float(p[1]), 1)): int(m)
            for p, m in zip(frame.uv, frame.markers, strict=True)}


def test_a_lost_track_does_not_push_a_running_one_onto_its_marker() -> None:
    """The swap has the smaller sum of link lengths (5.0 + 4.1 px against 1.7 + 9.9 px), but in
    expected misses (2 px running, 15 px after 0.1 s unseen) the right links win: each marker
    keeps its number; by link lengths alone the two swap."""
    spot = {'runner': tuple(RUNNER_SPOT.round(1)), 'still': tuple(STILL_SPOT.round(1))}
    right = run_crossing(TrackerConfig().lost_spread_px)
    assert right == {spot['runner']: 1, spot['still']: 2}, right
    swapped = run_crossing(0.0)
    assert swapped == {spot['runner']: 2, spot['still']: 1}, f'precondition: {swapped}'


def test_a_track_lost_a_frame_ago_keeps_its_spot_on_a_near_tie() -> None:
    """A track unseen for two frame periods predicts nearly as well as a running one. As on a
    fast dusk tuning look (``t107_dusk``'s side, two markers a frame after a merge): the
    running track links 6.2 px off, the lost one 1.9 px (8.1 px, the assignment's choice);
    the swap (2.1 + 7.0 px) is better in expected misses by 1.7 px, less than one running
    track's expected miss (2 px), so the links stay."""
    tracker = MarkerTracker(TrackerConfig(hold_rival_px=8.0))
    a, b = np.array([100.0, 100.0]), np.array([102.1, 101.9])
    tracker.seed(np.array([a, b]), np.array([1, 2], np.int32), -DT)
    tracker.update(0.0, dets(np.array([a, b])))
    tracker.update(DT, dets(np.array([a])))  # 2 covered for a frame
    a_spot, b_spot = a + np.array([3.82, -4.89]), np.array([102.1, 100.0])
    frame = tracker.update(2 * DT, dets(np.array([a_spot, b_spot])))
    got = {tuple(p): int(m) for p, m in zip(frame.uv.tolist(), frame.markers, strict=True)}
    assert got == {tuple(a_spot): 1, tuple(b_spot): 2}, got


def test_lost_spread_is_checked() -> None:
    """A negative lost spread is one clear error naming it."""
    try:
        TrackerConfig(lost_spread_px=-1.0)
    except ValueError as err:
        assert 'lost_spread_px' in str(err)
    else:
        raise AssertionError('lost_spread_px=-1 accepted')
