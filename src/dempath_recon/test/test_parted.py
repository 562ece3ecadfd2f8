"""A numbered track whose spot parts in two gives its number back (``tracking.parted``)."""

from __future__ import annotations

import numpy as np

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.parted import flagged, revoke_at_parting
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

DT = 0.02  # frame period [s]
GRID = ((-0.05, 0.0, -0.05), (0.05, 0.0, -0.05), (0.0, 0.0, 0.05))  # markers 1, 2, 3 [m]


def numbered_tracker(rig) -> StereoMarkerTracker:  # type: ignore[no-untyped-def]
    """A tracker that has numbered the three markers in both cameras (3 frames)."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=MarkerGrid(layout_m=GRID)))
    xyz = np.array(GRID)
    for k in range(3):
        for name in ('cam_side', 'cam_front'):
            uv = cams[name].project(xyz)
            tracker.update_detections(name, k * DT, Detections(uv, np.ones(3), np.full(3, 4.0)))
    return tracker


def test_a_track_whose_spot_parts_gives_its_number_back(rig) -> None:  # type: ignore[no-untyped-def]
    """A numbered track linked last frame to a crowded spot (two markers) and now to one part of
    a split blob, the other part 6 px away: its number is taken back for good (refused, said);
    a track whose last spot was not crowded, or a part with no other part beside it, keeps its
    number."""
    tracker = numbered_tracker(rig)
    state = tracker.state
    tracks = state.trackers['cam_front'].tracks
    ids = np.array([t.track_id for t in tracks], np.int64)
    markers = np.array([t.marker for t in tracks], np.int32)
    assert sorted(markers.tolist()) == [1, 2, 3]
    pts = np.array([t.uv for t in tracks], np.float64)
    # the first track's spot parted: a sibling part 6 px beside it
    sibling = pts[0] + np.array([6.0, 0.0])
    det = Detections(np.vstack([pts, sibling]), np.ones(4), np.full(4, 4.0),
                     parted=np.array([True, False, False, True]))
    assert flagged(det, det.parted, pts).tolist() == [True, False, False]
    crowded = {int(ids[0])}
    events: list[str] = []
    out = revoke_at_parting(state, 'cam_front', ids, markers, pts, det, crowded, 3 * DT, 8.0,
                            events)
    assert out.tolist() == [UNNUMBERED, *markers[1:].tolist()]
    assert tracks[0].marker == UNNUMBERED
    assert (int(ids[0]), int(markers[0])) in state.refused['cam_front']
    assert len(events) == 1 and 'gave back marker' in events[0]
    # its spot last frame was not crowded: no change
    tracks[0].marker = int(markers[0])
    kept = revoke_at_parting(state, 'cam_front', ids, markers, pts, det, set(), 3 * DT, 8.0, [])
    assert kept.tolist() == markers.tolist()
    # a part with no other part within 1.5 diameters: no change
    far = Detections(np.vstack([pts, pts[0] + np.array([30.0, 0.0])]), np.ones(4),
                     np.full(4, 4.0), parted=np.array([True, False, False, True]))
    kept = revoke_at_parting(state, 'cam_front', ids, markers, pts, far, crowded, 3 * DT, 8.0,
                             [])
    assert kept.tolist() == markers.tolist()
