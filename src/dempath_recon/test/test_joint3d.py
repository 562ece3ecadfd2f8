"""The joint two-camera 3D tracker (``StereoTrackConfig.engine = 'joint'``): identities decided
in 3D for both cameras at once, never guessed.

The scenes are 3D points projected exactly through the twin's true cameras (as in
``test_association``), so every detection's true marker is known; the front camera exposes
3 ms after the side one, as in the twin's renders.
"""

from __future__ import annotations

import numpy as np
import pytest

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.joint3d.assign import NONE, Option, assign
from dempath_recon.tracking.joint3d.engine import JointStereoTracker
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

DT = 0.02  # frame period [s]
OFFSET = 0.003  # the front camera exposes this much after the side one [s]
PITCH = 0.05  # the default grid's pitch [m]


def dets(cam, xyz: list[np.ndarray]) -> Detections:
    """Exact detections of the points (k, 3) m in one camera."""
    pts = np.asarray(xyz, np.float64).reshape(-1, 3)
    uv = cam.project(pts) if len(pts) else np.zeros((0, 2))
    return Detections(np.asarray(uv, np.float64), np.ones(len(uv)), np.full(len(uv), 4.0))


def run(rig, scene, config: StereoTrackConfig):
    """Feed (side points, front points) per frame (each a list of (3,) m) through the joint
    engine as the bench does (update, release, flush); the frames given out, per camera."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, config)
    out = []
    for k, (side_pts, front_pts) in enumerate(scene):
        tracker.update_detections('cam_side', k * DT, dets(cams['cam_side'], side_pts))
        out += tracker.release()
        tracker.update_detections('cam_front', k * DT + OFFSET,
                                  dets(cams['cam_front'], front_pts))
        out += tracker.release()
    out += tracker.flush()
    return ({n: [f for f in out if f.camera == n] for n in cams}, tracker)


def number_of(frame, cam, point: np.ndarray) -> int:
    """The number given to the detection of ``point`` in ``frame`` (-2: not detected)."""
    uv = cam.project(point[None])[0]
    d = np.linalg.norm(frame.uv - uv, axis=1) if len(frame.uv) else np.zeros(0)
    return int(frame.markers[int(np.argmin(d))]) if len(d) and d.min() < 0.01 else -2


def toward(cam, point: np.ndarray, dist_m: float) -> np.ndarray:
    """The point ``dist_m`` nearer ``cam`` on its line of sight through ``point``."""
    centre = -np.asarray(cam.R).T @ np.asarray(cam.t)
    ray = centre - point
    return point + dist_m * ray / np.linalg.norm(ray)


def test_markers_that_meet_and_turn_back_in_one_view_keep_their_numbers(rig) -> None:
    """Two markers at different depths along the front camera's line of sight approach each
    other in the front view, nearly touch and turn back (the side camera sees them well
    apart): a 2D tracker carried on by their image velocities would swap them. The joint
    assignment pairs each front spot with the side spot on its epipolar line, at the 3D
    point its motion allows: every number given out is right, both cameras number both
    markers after the turn."""
    front = rig.cameras[1]
    base1 = np.array([0.0, 0.0, 0.0])
    base2 = toward(front, base1, 0.04)
    axis = front.R[0]  # the front image's u direction, in the world
    grid = MarkerGrid(layout_m=(tuple(base1 + 0.012 * axis), tuple(base2 - 0.012 * axis),
                                (0.05, 0.0, 0.05)))
    p3 = np.array([0.05, 0.0, 0.05])
    steps = [0.012, 0.009, 0.006, 0.003, 0.0015, 0.003, 0.006, 0.009, 0.012]
    scene = [([base1 + s * axis, base2 - s * axis, p3],) * 2 for s in steps]
    gap = [np.linalg.norm(front.project(a[None]) - front.project(b[None]))
           for a, b, _ in (pts for pts, _ in scene)]
    assert min(gap) < 6, f'precondition: the spots come within {min(gap):.1f} px in the front'
    out, _ = run(rig, [(list(s), list(f)) for s, f in scene],
                 StereoTrackConfig(grid=grid, engine='joint'))
    for cam in rig.cameras:
        for k, frame in enumerate(out[cam.name]):
            p1, p2, _ = scene[k][0]
            got = (number_of(frame, cam, p1), number_of(frame, cam, p2))
            assert got[0] in (1, -1) and got[1] in (2, -1), f'{cam.name} frame {k}: {got}'
        last = out[cam.name][-1]
        p1, p2, _ = scene[-1][0]
        assert (number_of(last, cam, p1), number_of(last, cam, p2)) == (1, 2)


def test_first_frames_that_fit_the_grid_shifted_by_a_pitch_are_not_numbered(rig) -> None:
    """The grid lies 0.4 pitch along the travel from where it was laid; only markers 2, 3 and
    4 (the middle of the first row) show at first, so the grid fits them as well shifted back
    by one pitch: nothing is numbered (a guess would number every marker wrong for the pass).
    Marker 5 then shows too, only the right fit holds it, and all four are numbered right."""
    grid = MarkerGrid()
    numbers, xyz = grid.points()
    lift = np.array([0.0, 0.002, 0.4 * PITCH])
    at = {int(n): p + lift for n, p in zip(numbers, xyz, strict=True)}
    first = [at[2], at[3], at[4]]
    more = [*first, at[5]]
    scene = [(first, first)] * 3 + [(more, more)] * 3
    out, tracker = run(rig, scene, StereoTrackConfig(grid=grid, engine='joint'))
    for cam in rig.cameras:
        frames = out[cam.name]
        assert all((f.markers == -1).all() for f in frames[:3]), f'{cam.name}: guessed'
        assert [number_of(frames[-1], cam, at[m]) for m in (2, 3, 4, 5)] == [2, 3, 4, 5]
    assert isinstance(tracker.joint, JointStereoTracker)


def test_marker_seen_by_one_camera_is_numbered_there_alone(rig) -> None:
    """Marker 3, placed in 3D for a few frames, then covered in the front camera while it
    creeps on in the side camera's view: the side gives it out by its ray (it is where its 3D
    state says), the front gives its number to no other spot, and no pair is formed."""
    grid = MarkerGrid(layout_m=((-0.05, 0.0, -0.05), (0.05, 0.0, -0.05), (0.0, 0.0, 0.05)))
    p1, p2, p3 = (np.array(p) for p in grid.layout_m)
    stray = p3 + np.array([0.0, 0.0, 0.07])
    creep = [p3 + np.array([0.0, 0.0, 0.001 * k]) for k in range(8)]
    scene = [([p1, p2, creep[k]], [p1, p2, creep[k]]) for k in range(3)]
    scene += [([p1, p2, creep[k]], [p1, p2, stray]) for k in range(3, 8)]
    out, _ = run(rig, scene, StereoTrackConfig(grid=grid, engine='joint'))
    side, front = rig.cameras
    assert [number_of(f, side, creep[k]) for k, f in enumerate(out['cam_side'])] == [3] * 8
    assert [number_of(f, front, stray) for f in out['cam_front'][3:]] == [-1] * 5
    assert [number_of(f, front, p1) for f in out['cam_front']] == [1] * 8


def test_assignment_withholds_a_marker_with_a_rival_spot() -> None:
    """Two spots equally near a marker's prediction: the assignment takes one but marks the
    marker unsure in that camera; a lone spot is sure."""
    xyz = np.zeros(3)
    caps = np.ones(3, np.int64)
    twin = [Option(0, 0, NONE, 8.0, xyz), Option(0, 1, NONE, 8.5, xyz)]
    lone = [Option(0, 0, NONE, 8.0, xyz), Option(0, 1, NONE, 20.0, xyz)]
    assert not assign(twin, caps, caps, 4.0)[0].sure_a
    assert assign(lone, caps, caps, 4.0)[0].sure_a


def test_engine_name_is_checked() -> None:
    """An unknown engine is refused with a message naming the field."""
    with pytest.raises(ValueError, match='engine'):
        StereoTrackConfig(engine='kalman')
