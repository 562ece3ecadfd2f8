"""The publication delay fills a point withheld for the other camera once that camera confirms
it (``release.fill_confirmed``), and only then."""

from __future__ import annotations

import numpy as np

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.linker import TrackerConfig
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

DT = 0.02  # frame period [s]
OFFSET = 0.003  # the front camera exposes this much after the side one [s]
GRID = ((-0.05, 0.0, -0.05), (0.05, 0.0, -0.05), (0.0, 0.0, 0.05))  # markers 1, 2, 3 [m]


def released(rig, scene: list[tuple[list[np.ndarray], list[np.ndarray]]],
             config: StereoTrackConfig):
    """Feed (side points, front points) per frame; the frames ``release``/``flush`` give out,
    per camera, and the tracker."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, config)
    out = []
    for k, (side_pts, front_pts) in enumerate(scene):
        for name, pts, t in (('cam_side', side_pts, k * DT),
                             ('cam_front', front_pts, k * DT + OFFSET)):
            uv = cams[name].project(np.array(pts, np.float64).reshape(-1, 3))
            tracker.update_detections(name, t, Detections(uv, np.ones(len(uv)),
                                                          np.full(len(uv), 4.0)))
            out += tracker.release()
    out += tracker.flush()
    return ({n: [f for f in out if f.camera == n] for n in cams}, tracker)


def number_of(frame, cam, point: np.ndarray) -> int:
    """The number given to the detection of ``point`` in ``frame`` (-2: not detected)."""
    d = np.linalg.norm(frame.uv - cam.project(point[None])[0], axis=1)
    return int(frame.markers[int(np.argmin(d))]) if len(d) and d.min() < 0.01 else -2


def _reattached_scene(side_back: bool) -> tuple[list, np.ndarray]:
    """Markers 2 and 3 covered in both cameras; 3 back 20 mm aside in the front from frame 5,
    in the side from frame 7 (``side_back``) or never."""
    p1, p2, p3 = (np.array(g) for g in GRID)
    moved = p3 + np.array([0.02, 0.0, 0.0])
    scene = [([p1, p2, p3], [p1, p2, p3])] * 3 + [([p1], [p1])] * 2
    scene += [([p1], [p1, moved])] * 2
    scene += [([p1, moved] if side_back else [p1], [p1, moved])] * 3
    return scene, moved


def test_withheld_reattachment_goes_out_numbered_once_confirmed(rig) -> None:
    """The front re-attaches marker 3 about 20 px off and withholds it (frames 5-6) until the
    side sees it too (frame 7): the held frames 5-6 go out numbered 3, as frames 7-9 do."""
    scene, moved = _reattached_scene(side_back=True)
    config = StereoTrackConfig(grid=MarkerGrid(layout_m=GRID),
                               tracker=TrackerConfig(reattach_px=80.0))
    out, tracker = released(rig, scene, config)
    front = rig.cameras[1]
    assert [number_of(f, front, moved) for f in out['cam_front'][5:10]] == [3] * 5
    assert tracker.report()['cam_front']['unconfirmed'] == 2
    assert tracker.report()['cam_front']['confirmed_late'] == 2


def test_withheld_reattachment_never_confirmed_stays_withheld(rig) -> None:
    """The same re-attachment that the side never confirms is never given out as marker 3."""
    scene, moved = _reattached_scene(side_back=False)
    config = StereoTrackConfig(grid=MarkerGrid(layout_m=GRID),
                               tracker=TrackerConfig(reattach_px=80.0))
    out, tracker = released(rig, scene, config)
    front = rig.cameras[1]
    assert [number_of(f, front, moved) for f in out['cam_front'][5:10]] == [-1] * 5
    assert tracker.report()['cam_front']['confirmed_late'] == 0
