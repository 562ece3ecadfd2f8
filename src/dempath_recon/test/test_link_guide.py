"""The other camera inside the 2D link (``link_guide``, ``MarkerTracker.update``'s ``barred``),
spots that may hold two markers, and faint spots taken by the track that lost its marker.
Synthetic detections at exact positions, and a synthetic frame with a faded marker."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import Detections, DetectorConfig, MarkerDetector
from dempath_recon.tracking.link_guide import MERGE_S, ambiguous_spots
from dempath_recon.tracking.linker import MarkerTracker
from dempath_recon.tracking.numbering import nearer_grid_point
from dempath_recon.tracking.records import StereoTrackConfig
from dempath_recon.tracking.state import StereoState

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


def faded_image(alpha: float) -> np.ndarray:
    """A 240x320 BGR frame: a clay marker at (100.3, 120.6) and one at (200.7, 110.2) blended
    into the sand at ``alpha`` (a half-buried marker in a dark frame keeps that share of its
    contrast)."""
    c = np.array([[100.3, 120.6], [200.7, 110.2]])
    both = cv2.imdecode(np.frombuffer(spot_image((240, 320), c, 4.5, np.random.default_rng(3),
                                                 quality=95), np.uint8), 1).astype(float)
    one = cv2.imdecode(np.frombuffer(spot_image((240, 320), c[:1], 4.5,
                                                np.random.default_rng(3), quality=95),
                                     np.uint8), 1).astype(float)
    img = one * (1 - alpha) + both * alpha
    img[:, :150] = one[:, :150]
    return np.clip(img, 0, 255).astype(np.uint8)


def test_faint_marker_is_reported_apart_and_taken_only_by_its_track() -> None:
    """A marker at 55 % of its contrast is below the threshold: not a detection but a faint
    spot, found near a point asked for (none searched with ``faint_threshold`` 0); the
    numbered track that lost it takes it (within ``faint_gate_px``), an unnumbered track never
    does, and it never starts a track."""
    det = MarkerDetector().detect(faded_image(0.55))
    assert len(det.uv) == 1 and np.linalg.norm(det.uv[0] - [100.3, 120.6]) < 0.3
    assert det.faint is not None
    found = det.faint(np.array([[202.0, 111.0], [100.0, 121.0], [60.0, 60.0]]), 4.0)
    assert np.linalg.norm(found[0] - [200.7, 110.2]) < 1.0  # the faded marker
    assert np.isnan(found[1:]).all()  # the strong marker's own spot, and bare sand
    assert MarkerDetector(DetectorConfig(faint_threshold=0.0)).detect(
        faded_image(0.55)).faint is None
    for number, want in ((7, [-1, 7]), (-1, [-1])):
        tracker = MarkerTracker()
        tracker.seed(np.array([[100.0, 120.0], [201.0, 111.0]]),
                     np.array([-1, number], np.int32), -DT)
        frame = tracker.update(0.0, det)
        assert sorted(frame.markers.tolist()) == want
        assert tracker.counts.new_tracks == 0 and tracker.counts.faint == len(want) - 1


def test_spot_on_another_unseen_markers_grid_point_is_not_the_candidate(rig) -> None:
    """A spot 1 px from marker 10's grid point and 28 px from 14's, neither seen by this
    camera: it is 10's, not 14's (``nearer_grid_point``); once 10 has been seen, 14 may be."""
    cams = {c.name: c for c in rig.cameras}
    state = StereoState.start(cams, StereoTrackConfig(grid=MarkerGrid(
        layout_m=((0.0, 0.0, 0.0), (0.025, 0.0, 0.0)))))
    state.grid_uv['cam_side'] = {10: np.array([902.0, 544.0]), 14: np.array([927.0, 558.0])}
    spot = np.array([902.5, 544.8])
    assert nearer_grid_point(state, 'cam_side', 14, spot) == 10
    assert nearer_grid_point(state, 'cam_side', 10, spot) is None
    state.latest['cam_side'][10] = (0.0, spot)
    assert nearer_grid_point(state, 'cam_side', 14, spot) is None
