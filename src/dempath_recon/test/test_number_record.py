"""The record of which rule numbered what (``tracking.number_record``), on the two-camera tracker
run over a known scene in the twin's true cameras."""

from __future__ import annotations

import numpy as np

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.number_record import REATTACHED
from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

DT = 0.02  # frame period [s]
GRID = ((-0.05, 0.0, -0.05), (0.05, 0.0, -0.05), (0.0, 0.0, 0.05), (0.05, 0.0, 0.05))  # 1-4 [m]


def run_scene(rig, record: bool) -> tuple[StereoMarkerTracker, list[PixelFrame]]:  # type: ignore[no-untyped-def]
    """Markers 1-3 in both cameras from the start (the grid fit), marker 4 from frame 3 (a new
    track in each camera), marker 1 hidden from the front camera in frames 4 and 5 (its track
    lost, then re-attached)."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(
        grid=MarkerGrid(layout_m=GRID), record_numbers=record, number_delay_frames=0))
    xyz, out = np.array(GRID), []
    for k in range(8):
        for name in ('cam_side', 'cam_front'):
            keep = [0, 1, 2] + ([3] if k >= 3 else [])
            if name == 'cam_front' and k in (4, 5):
                keep.remove(0)
            uv = cams[name].project(xyz[keep])
            out.append(tracker.update_detections(
                name, k * DT, Detections(uv, np.ones(len(uv)), np.full(len(uv), 4.0))))
    return tracker, out


def test_each_number_is_recorded_with_its_rule_frame_and_evidence(rig) -> None:  # type: ignore[no-untyped-def]
    """Markers 1-3 are numbered by the grid fit, marker 4 later by ``number_new`` (its grid
    point in the side camera, the epipolar line in the front one), each with the rule's own
    event as evidence; the front's re-attachment of marker 1 is noted; each point given out
    traces back to the change behind its number."""
    tracker, out = run_scene(rig, record=True)
    record = tracker.state.record
    assert record is not None
    fours = [c for c in record.changes if c.after == 4]
    assert {(c.camera, c.rule, c.stamp_s) for c in fours} == {
        ('cam_side', 'number_new', 3 * DT), ('cam_front', 'number_new', 3 * DT)}
    for c in fours:
        assert c.before == -1 and c.seen_s == 3 * DT
        assert len(c.evidence) == 1 and f'{c.camera}: track {c.track_id} numbered marker 4' \
            in c.evidence[0], c.evidence
    assert {c.rule for c in record.changes if c.after in (1, 2, 3) and c.rule != REATTACHED} \
        == {'grid_fit'}
    back = [c for c in record.changes if c.rule == REATTACHED]
    assert [(c.camera, c.before, c.after, c.stamp_s) for c in back] == [
        ('cam_front', 1, 1, 6 * DT)]
    last = out[-1]
    assert sorted(last.markers.tolist()) == [1, 2, 3, 4]
    for k, m in enumerate(last.markers.tolist()):
        change = record.behind(last.camera, last.stamp_s, k, m)
        assert change is not None and change.after == m
        assert change.rule == ('number_new' if m == 4 else 'grid_fit')
        assert change.track_id == record.track_of(last.camera, last.stamp_s, k)
        assert record.arrival_number(last.camera, last.stamp_s, k) == m
    assert record.behind(last.camera, last.stamp_s, 0, 9) is None  # never given 9


def test_the_record_changes_nothing(rig) -> None:  # type: ignore[no-untyped-def]
    """The same frames and numbers with the record on and off; off, nothing is kept and the
    linkers call nobody."""
    with_record, on = run_scene(rig, record=True)
    without, off = run_scene(rig, record=False)
    assert without.state.record is None
    assert all(t.on_number is None for t in without.state.trackers.values())
    assert len(on) == len(off)
    for a, b in zip(on, off, strict=True):
        assert a.markers.tolist() == b.markers.tolist() and np.array_equal(a.uv, b.uv)
        assert a.events == b.events
    assert with_record.state.record is not None
    assert len(with_record.state.record.frames) == len(on)
