"""Numbering in 3D over the whole pass (``tracking.joint_fill``): spots left unnumbered filled
from each marker's 3D path, jointly in both cameras.

Scenes are the 15-marker grid moved by a slow bed flow and projected through the twin's true
cameras, each camera's points given out as a frame-by-frame pipeline might have left them, so
each point's marker is known.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from projected import DT, GRID15, OFFSET

from dempath_recon.tracking.joint_fill import (
    ACCEL_M_S2,
    BASE_M,
    Path3D,
    fill_jointly,
    predict,
)
from dempath_recon.tracking.records import PixelFrame

FLOW = np.array([0.0, 0.0004, 0.0008])  # the bed's slow heave and travel [m/frame]
FRAMES = 20
EPIPOLAR_PX = 4.0
FPS = 1 / DT
GAP = range(8, 12)  # the frames where the rules left marker 8 unnumbered


def _grid(k: int) -> dict[int, np.ndarray]:
    """The 15 markers at frame ``k`` [m]."""
    return {m: np.array(p) + k * FLOW for m, p in enumerate(GRID15, 1)}


def _frames(rig, pts: list[dict[int, np.ndarray]], numbered, seen,
            ) -> tuple[list[PixelFrame], list[np.ndarray]]:
    """Both cameras' frames: ``pts[k]`` marker -> (3,) m at frame ``k``; ``seen(cam, k, m)``
    whether the camera found it, ``numbered(cam, k, m)`` the number it gave (-1 none); each
    marker's points one 2D track per camera (id 100 + marker)."""
    frames, track_ids = [], []
    for k, at in enumerate(pts):
        for cam, dt in (('cam_side', 0.0), ('cam_front', OFFSET)):
            model = next(c for c in rig.cameras if c.name == cam)
            here = [m for m in at if seen(cam, k, m)]
            frames.append(PixelFrame(cam, k * DT + dt,
                                     np.array([numbered(cam, k, m) for m in here], np.int32),
                                     model.project(np.array([at[m] for m in here])),
                                     np.ones(len(here)), ()))
            track_ids.append(np.array([100 + m for m in here], np.int64))
    return frames, track_ids


def _numbers(frames: list[PixelFrame], track_ids: list[np.ndarray], cam: str, marker: int,
             ) -> list[int]:
    """The numbers ``cam``'s points of ``marker`` (its track) were given out with, frame by
    frame (-2: not seen)."""
    out = []
    for f, t in zip(frames, track_ids, strict=True):
        if f.camera == cam:
            hit = f.markers[t == 100 + marker]
            out.append(int(hit[0]) if len(hit) else -2)
    return out


def test_the_prediction_follows_the_path_and_its_gate_grows_with_the_gap() -> None:
    """Between anchors the point is linear and the gate grows as a |(t-t0)(t-t1)| / 2; past
    an end it is extrapolated a few frames, then nothing."""
    times = np.array([0.0, 0.02, 0.1])
    path = Path3D(times, np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.02], [0.0, 0.0, 0.1]]))
    mid = predict(path, 0.06, FPS)
    assert mid is not None
    assert np.allclose(mid.xyz, [0.0, 0.0, 0.06])
    assert np.isclose(mid.gate_m, BASE_M + 0.5 * ACCEL_M_S2 * 0.04 * 0.04)
    ahead = predict(path, 0.14, FPS)
    assert ahead is not None and np.allclose(ahead.xyz, [0.0, 0.0, 0.14])
    assert predict(path, 0.2, FPS) is None  # five frames past the end


def test_a_marker_left_unnumbered_in_both_cameras_is_filled_from_its_path(rig) -> None:
    """Marker 8, numbered in both cameras but for four frames mid-pass where both found it
    and left it unnumbered, takes 8 there in both: the pair lies on its line and on 8's path."""
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)],
                                lambda cam, k, m: -1 if (m == 8 and k in GAP) else m,
                                lambda cam, k, m: True)
    out, given = fill_jointly(frames, track_ids, {c.name: c for c in rig.cameras},
                              EPIPOLAR_PX, FPS)
    assert given == 2 * len(GAP)
    for cam in ('cam_side', 'cam_front'):
        assert _numbers(out, track_ids, cam, 8) == [8] * FRAMES


def test_a_marker_hidden_in_one_camera_is_filled_where_it_is_alone_in_its_gate(rig) -> None:
    """Marker 8 hidden in the side for four frames: the front's unnumbered spot of 8, alone
    where 8's path projects, takes 8; the side's frames have no spot of it to number."""
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)],
                                lambda cam, k, m: -1 if (m == 8 and k in GAP) else m,
                                lambda cam, k, m: not (cam == 'cam_side' and m == 8
                                                       and k in GAP))
    out, given = fill_jointly(frames, track_ids, {c.name: c for c in rig.cameras},
                              EPIPOLAR_PX, FPS)
    assert given == len(GAP)
    assert _numbers(out, track_ids, 'cam_front', 8) == [8] * FRAMES


def test_a_spot_on_the_line_but_off_the_path_is_not_filled(rig) -> None:
    """Marker 8 hidden in the front for four frames while a marker nobody numbered (16) sits
    on the side's line of sight through 8, 30 mm farther: in the front 16's spot lies on 8's
    epipolar line (what an epipolar back-fill would number 8), but far from where 8's path
    projects, so it stays unnumbered."""
    side = next(c for c in rig.cameras if c.name == 'cam_side')
    centre = -np.asarray(side.R).T @ np.asarray(side.t).ravel()
    pts = []
    for k in range(FRAMES):
        at = _grid(k)
        if k in GAP:
            ray = (at[8] - centre) / np.linalg.norm(at[8] - centre)
            at[16] = at[8] + 0.03 * ray
        pts.append(at)
    frames, track_ids = _frames(
        rig, pts, lambda cam, k, m: -1 if m == 16 else m,
        lambda cam, k, m: not (m == 16 and cam == 'cam_side')
        and not (m == 8 and cam == 'cam_front' and k in GAP))
    out, given = fill_jointly(frames, track_ids, {c.name: c for c in rig.cameras},
                              EPIPOLAR_PX, FPS)
    assert given == 0
    assert _numbers(out, track_ids, 'cam_front', 16) == [-2] * 8 + [-1] * 4 + [-2] * 8


def test_two_markers_predicted_at_one_spot_leave_it_unnumbered(rig) -> None:
    """Marker 7 runs beside 8 all pass (1 mm apart, two spots); for four frames the two are
    one spot in both cameras, left unnumbered: both paths pass it, the spot could be either
    (two explanations as good): refused."""
    pts = []
    for k in range(FRAMES):
        at = _grid(k)
        at[7] = at[8] + np.array([0.001, 0.0, 0.0])
        pts.append(at)
    frames, track_ids = _frames(rig, pts, lambda cam, k, m: -1 if m in (7, 8) and k in GAP
                                else m, lambda cam, k, m: not (m == 7 and k in GAP))
    out, given = fill_jointly(frames, track_ids, {c.name: c for c in rig.cameras},
                              EPIPOLAR_PX, FPS)
    assert given == 0
    assert _numbers(out, track_ids, 'cam_side', 8)[8:12] == [-1] * 4


def test_a_path_is_carried_on_past_its_end_pass_by_pass(rig) -> None:
    """Marker 8, numbered in both cameras for the first ten frames, then found and left
    unnumbered in both till the pass ends: each pass carries its path a few frames on (the
    filled pairs are the next pass's anchors), to the last frame."""
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)],
                                lambda cam, k, m: -1 if (m == 8 and k >= 10) else m,
                                lambda cam, k, m: True)
    out, given = fill_jointly(frames, track_ids, {c.name: c for c in rig.cameras},
                              EPIPOLAR_PX, FPS)
    assert given == 2 * (FRAMES - 10)
    assert _numbers(out, track_ids, 'cam_front', 8) == [8] * FRAMES


def test_a_track_that_ran_beside_the_marker_is_not_filled_with_it(rig) -> None:
    """Marker 8 sinks out of the front's view at frame 10 while a marker nobody numbered (16)
    runs 4 mm beside it: 16's spot lies within 8's gate once 8 is gone, but its 2D track was
    seen beside 8's given point a frame before, so it is not 8."""
    pts = []
    for k in range(FRAMES):
        at = _grid(k)
        at[16] = at[8] + np.array([0.004, 0.0, 0.0])
        pts.append(at)
    frames, track_ids = _frames(
        rig, pts, lambda cam, k, m: -1 if m == 16 else m,
        lambda cam, k, m: not (m == 16 and cam == 'cam_side')
        and not (m == 8 and cam == 'cam_front' and k >= 10))
    out, _ = fill_jointly(frames, track_ids, {c.name: c for c in rig.cameras}, EPIPOLAR_PX,
                          FPS)
    assert set(_numbers(out, track_ids, 'cam_front', 16)) == {-1}
