"""A number a crowded same-instant pair took back is given back once the track is on its own
marker again (``tracking.crowded_pair.give_back``), on the detections of a rendered tuning look
(``tune6_default``: the front's track of marker 10 slid onto sinking marker 9's spot, lost its
number there, and came back onto 10 while 9's lost track still lay beside it)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from test_crowded_pair import replay

DATA = Path(__file__).parent / 'data' / 'crowd_give_back_frames.json'
OWNER_PX = 8.0  # a point's marker is the true one nearest within this (the bench's rule)
OWN_PX = 3.0  # ... unless its own marker lies this near


def given_out(give_back: bool) -> tuple[list[tuple[str, float, int]], list[tuple[str, float,
                                                                                   int, int]]]:
    """The look's frames through the tracker: (points given their own number (camera, stamp
    s, number), points given another marker's number (camera, stamp s, number, true marker)),
    with the give-back ``give_back`` or off (the whole pass's piece numbering off)."""
    data, frames = replay(DATA, crowd_give_back=give_back, piece_numbering=False)  # this rule
    # alone: the whole pass's piece numbering numbers more of the side's 10 with it on
    ids: list[int] = data['marker_ids']
    truth = {(f['camera'], round(f['stamp_s'] * 1e6)): np.array(f['true_uv'])
             for f in data['frames']}
    right, wrong = [], []
    for frame in frames:
        true_uv = truth[(frame.camera, round(frame.stamp_s * 1e6))]
        for m, p in zip(frame.markers.tolist(), frame.uv, strict=True):
            if m < 0:
                continue
            d = np.linalg.norm(true_uv - p, axis=1)
            if d[ids.index(m)] <= OWN_PX:
                right.append((frame.camera, round(frame.stamp_s, 3), m))
            elif d.min() <= OWNER_PX:
                wrong.append((frame.camera, round(frame.stamp_s, 3), m,
                              int(ids[int(np.argmin(d))])))
    return right, wrong


def test_a_taken_back_number_is_given_back_on_its_own_marker_only() -> None:
    """With the give-back, the front's track of 10 is given 10 back after three clear frames
    and goes out with it on 10's own spot in the six front frames left; nothing goes out
    wrongly that did not without it (the frames it held from before the clear row, on 9's
    spot, stay unnumbered)."""
    right_on, wrong_on = given_out(True)
    right_off, wrong_off = given_out(False)
    gained = sorted(set(right_on) - set(right_off))
    assert not set(right_off) - set(right_on)
    assert gained == [('cam_front', round(1700000001.625 + 0.02 * i, 3), 10) for i in range(6)]
    assert sorted(wrong_on) == sorted(wrong_off)
