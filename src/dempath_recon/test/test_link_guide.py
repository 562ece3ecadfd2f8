"""The other camera inside the 2D link (``link_guide``, ``MarkerTracker.update``'s ``barred``)
and spots that may hold two markers. Synthetic detections at exact positions."""

from __future__ import annotations

import numpy as np

from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.link_guide import MERGE_S, ambiguous_spots
from dempath_recon.tracking.linker import MarkerTracker

DT = 0.02  # frame period [s]


def dets(uv: list[list[float]]) -> Detections:
    """Detections at exact positions (px)."""
    a = np.asarray(uv, np.float64).reshape(-1, 2)
    return Detections(a, np.ones(len(a)), np.full(len(a), 3.0))


def test_barred_detection_is_never_linked() -> None:
    """A spot 3 px from marker 1's prediction, barred for its track: a new unnumbered track,
    and marker 1's track lost with its number; unbarred, the same spot is linked as 1."""
    for barred, want in ((True, -1), (False, 1)):
        tracker = MarkerTracker()
        tracker.seed(np.array([[100.0, 100.0]]), np.array([1], np.int32), -DT)
        tracker.update(0.0, dets([[100.0, 100.0]]))
        bar = {0: np.array([True])} if barred else None
        frame = tracker.update(DT, dets([[103.0, 100.0]]), bar)
        assert list(frame.markers) == [want]
        assert tracker.tracks[0].marker == 1 and tracker.tracks[0].lost is barred


def test_spot_beside_a_just_lost_track_may_hold_both() -> None:
    """Markers 1 and 2, 5 px apart, merge into one spot between them: the spot (linked to
    one of them) may hold both, with 8 px markers; not once the other has been lost longer
    than ``MERGE_S``, nor with no marker size known."""
    tracker = MarkerTracker()
    tracker.seed(np.array([[100.0, 100.0], [100.0, 105.0]]), np.array([1, 2], np.int32), -DT)
    tracker.update(0.0, dets([[100.0, 100.0], [100.0, 105.0]]))
    frame = tracker.update(DT, dets([[100.0, 102.0]]))
    assert list(ambiguous_spots(tracker, frame, 8.0)) == [True]
    assert list(ambiguous_spots(tracker, frame, 0.0)) == [False]
    assert list(ambiguous_spots(tracker, frame, 2.5)) == [False]  # 3 px off: beyond a diameter
    k = 2
    while k * DT - DT <= MERGE_S:
        frame = tracker.update(k * DT, dets([[100.0, 102.0]]))
        k += 1
    assert list(ambiguous_spots(tracker, frame, 8.0)) == [False]
