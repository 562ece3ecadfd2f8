"""A track whose spot a neighbour's blob merged into gives its number back
(``tracking.merge_release``), on the detections of a rendered long-pass look (tuning look
``t105_coh``: in the front view marker 9 runs into the spot of marker 14, standing still; the
spot grows, 9's track is left unlinked beside it, 14 sinks and its track followed 9) and on
tracks placed by hand."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from test_crowded_pair import hand_state, wrong_points

from dempath_recon.tracking.merge_release import (
    GROWTH,
    keep_released_free,
    merged_spots,
    release_merged,
    spot_sizes,
)
from dempath_recon.tracking.records import PixelFrame

DATA = Path(__file__).parent / 'data' / 'merge_release_frames.json'


def switched_points(on: bool) -> list[tuple[str, float, int, int]]:
    """The look's 25 frames a camera through the tracker: each point given out on another
    marker's spot (camera, stamp s, number, true marker), with the rule ``on`` or off."""
    return wrong_points(DATA, merge_release=on)


def test_a_blob_that_swallowed_a_neighbour_is_not_given_out_as_the_sunk_marker() -> None:
    """With the rule off the front's track of 14 goes out on marker 9's spot after the merge
    (front frames 1.825-1.885 s); with it, 14 never goes out on 9 and no point goes out on
    another marker's spot that did not without it."""
    off = switched_points(False)
    on = switched_points(True)
    assert sum(w[2:] == (14, 9) for w in off) == 4, off
    assert not [w for w in on if w[2:] == (14, 9)], on
    assert set(on) <= set(off), (on, off)


def test_a_merge_needs_a_track_left_unlinked_beside_a_grown_spot() -> None:
    """Track 0's spot grew by GROWTH and track 1, running a frame before, was left unlinked
    with its prediction in that spot: merged. The same growth with nobody left beside it, or
    a neighbour left beside a spot that did not grow, is no merge."""
    state = hand_state()
    front = state.trackers['cam_front']
    d = front.config.hold_rival_px or 0.0
    front.seed(np.array([[900.0, 500.0], [900.0 + 0.5 * d, 500.0], [1200.0, 500.0]]),
               np.array([14, 9, 3], np.int32), 10.0)
    ids = np.array([0, 1, 2], np.int64)
    uv = np.array([t.uv for t in front.tracks])
    state.last_tracks['cam_front'] = (10.0, ids, uv)
    state.spot_sizes['cam_front'] = {0: [2.0, 2.1, 2.0], 1: [2.0], 2: [2.0, 2.0]}
    front.tracks[1].lost = True  # track 1 left unlinked in the frame at 10.02 s
    for t in (front.tracks[0], front.tracks[2]):
        t.last_stamp_s = 10.02
    now = np.array([[900.0, 500.0], [1200.0, 500.0]])
    grown = np.array([GROWTH * 2.0 + 0.01, GROWTH * 2.0 + 0.01])
    merged = merged_spots(state, 'cam_front', np.array([0, 2]), now, grown, 10.02, d)
    assert merged.tolist() == [True, False]  # track 2 grew with nobody beside it
    state.last_tracks['cam_front'] = (10.0, ids, uv)
    state.spot_sizes['cam_front'] = {0: [2.0, 2.1, 2.0], 2: [2.0, 2.0]}
    same = np.array([2.1, 2.0])
    assert not merged_spots(state, 'cam_front', np.array([0, 2]), now, same, 10.02, d).any()


def test_a_released_number_is_refused_and_its_held_points_stay_unnumbered() -> None:
    """The merged spot's track gives its number back (refused for good); a later number
    does not reach the frames held from before it was given."""
    state = hand_state()
    front = state.trackers['cam_front']
    front.seed(np.array([[900.0, 500.0], [1200.0, 500.0]]), np.array([14, 3], np.int32), 10.0)
    events: list[str] = []
    out = release_merged(state, 'cam_front', np.array([0, 1]), np.array([14, 3], np.int32),
                         np.array([True, False]), 10.0, events)
    assert out.tolist() == [-1, 3] and (0, 14) in state.refused['cam_front']
    assert front.tracks[0].marker == -1 and len(events) == 1
    held = PixelFrame('cam_front', 10.0, out, np.array([[900.0, 500.0], [1200.0, 500.0]]),
                      np.ones(2), ())
    free = np.array([True, False])
    state.queue.hold(held, np.array([0, 1]), free, np.full(2, -1, np.int32))
    keep_released_free(state, 'cam_front', 10.02)
    assert free.tolist() == [False, False]  # the held point is no longer free to renumber
    front.number(0, 9)  # numbered again: no longer watched
    keep_released_free(state, 'cam_front', 10.04)
    assert not state.merge_freed['cam_front']


def test_spot_sizes_are_those_of_the_detections_the_points_took() -> None:
    """A point on a detection takes its size; a point on none (a faint spot) is NaN."""
    det_uv = np.array([[10.0, 10.0], [50.0, 50.0]])
    sizes = spot_sizes(np.array([[50.0, 50.0], [30.0, 30.0]]), det_uv, np.array([2.0, 3.0]))
    assert sizes[0] == 3.0 and np.isnan(sizes[1])
