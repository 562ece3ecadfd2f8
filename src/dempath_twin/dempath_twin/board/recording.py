"""The twin's calibration recording: board poses, rendered frames, bag, truth, point sets.

``calibration_poses`` mimics how a person calibrates: the board first lies on the sand (it
defines the world frame: centre at the origin, rows along +Z, printed face up), then it is
held in the volume both cameras share, and finally close to each camera in turn to cover its
image for the intrinsics. All draws are seeded.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterator
from itertools import pairwise
from pathlib import Path
from typing import Any, NamedTuple

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_calib.board import PAPER_BOARD, SURFACE_ROT, BoardSpec
from dempath_calib.camera import CameraModel, StereoCalibration
from dempath_calib.pointset import PointSet, make_point_set
from dempath_twin.board.renderer import BoardRenderer, FrameConditions
from dempath_twin.rig import WORKING_VOLUME, paper_rig

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
MAX_INCIDENCE_DEG = 60.0  # largest angle between the board normal and a camera's line of sight
DETECTABLE_DEG = 75.0  # incidence up to which project_views reports corners (detector limit)
IMAGE_MARGIN_PX = 15.0  # board corners kept this far inside the image when the board must fit


class BoardPose(NamedTuple):
    """Board pose ``X_world = rot @ p_board + t`` (metres) and the phase it belongs to."""

    rot: FloatArray
    t: FloatArray
    phase: str  # 'surface', 'shared', 'cam_side' or 'cam_front'


def surface_pose(board: BoardSpec) -> BoardPose:
    """The board lying on the sand, centred on the world origin (defines the world frame)."""
    return BoardPose(SURFACE_ROT.copy(), -SURFACE_ROT @ board.center_m, 'surface')


def _rotation_facing(normal: FloatArray, spin: float) -> FloatArray:
    """Board rotation whose printed face (-z) looks along ``normal``, spun by ``spin`` rad."""
    z = -normal / np.linalg.norm(normal)
    helper = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    x, y = np.cos(spin) * x + np.sin(spin) * y, -np.sin(spin) * x + np.cos(spin) * y
    return np.column_stack([x, y, z])


def _tilt(direction: FloatArray, max_deg: float, rng: np.random.Generator) -> FloatArray:
    """``direction`` rotated by up to ``max_deg`` about a random perpendicular axis."""
    axis = np.cross(direction, rng.standard_normal(3))
    axis *= np.radians(rng.uniform(0, max_deg)) / np.linalg.norm(axis)
    return cv2.Rodrigues(axis)[0] @ direction


def fits(camera: CameraModel, board: BoardSpec, pose: BoardPose, whole: bool = True,
         max_incidence_deg: float = MAX_INCIDENCE_DEG) -> bool:
    """True when the board faces ``camera`` and (all / some) corners fall inside its image."""
    corners = board.object_points() @ pose.rot.T + pose.t
    sight = camera.center - corners.mean(0)
    normal = -pose.rot[:, 2]
    cos_inc = normal @ sight / np.linalg.norm(sight)
    if cos_inc < np.cos(np.radians(max_incidence_deg)):
        return False
    uv = camera.project(corners)
    m = IMAGE_MARGIN_PX
    inside = (uv[:, 0] > m) & (uv[:, 0] < camera.width - m) & (uv[:, 1] > m) \
        & (uv[:, 1] < camera.height - m)
    return bool(inside.all() if whole else inside.mean() > 0.5)


def _shared_pose(rig: StereoCalibration, board: BoardSpec,
                 rng: np.random.Generator) -> BoardPose:
    lo, hi = WORKING_VOLUME
    centre = lo + (hi - lo) * rng.random(3) + np.array([0.0, 0.08, 0.0])
    bisector = sum((c.center - centre) / np.linalg.norm(c.center - centre) for c in rig.cameras)
    rot = _rotation_facing(_tilt(bisector / np.linalg.norm(bisector), 25.0, rng),
                           rng.uniform(-np.pi, np.pi))
    return BoardPose(rot, centre - rot @ board.center_m, 'shared')


def _close_pose(camera: CameraModel, board: BoardSpec, rng: np.random.Generator) -> BoardPose:
    uv = rng.uniform([0.12, 0.12], [0.88, 0.88]) * [camera.width, camera.height]
    ray = camera.R.T @ np.append(camera.undistort_points(uv[None], normalized=True)[0], 1.0)
    centre = camera.center + rng.uniform(0.45, 0.8) * ray / np.linalg.norm(ray)
    toward = (camera.center - centre) / np.linalg.norm(camera.center - centre)
    rot = _rotation_facing(_tilt(toward, 40.0, rng), rng.uniform(-0.6, 0.6))
    return BoardPose(rot, centre - rot @ board.center_m, camera.name)


def calibration_poses(n_views: int, seed: int = 0, rig: StereoCalibration | None = None,
                      board: BoardSpec = PAPER_BOARD, n_surface: int = 3,
                      shared_fraction: float = 0.5) -> list[BoardPose]:
    """Board poses of a calibration recording.

    Args:
        n_views: total number of poses (frames), including the surface ones.
        seed: random seed.
        rig: true cameras (``paper_rig()`` by default).
        board: the target.
        n_surface: first frames with the board lying on the sand.
        shared_fraction: share of the remaining frames in the common field of view; the rest
            alternate close to the side and the front camera.

    Returns:
        ``n_views`` poses, surface ones first.
    """
    rig = rig or paper_rig()
    rng = np.random.default_rng(seed)
    poses = [surface_pose(board)] * min(n_surface, n_views)
    n_shared = round((n_views - len(poses)) * shared_fraction)
    while len(poses) < n_views:
        k = len(poses) - n_surface
        if k < n_shared:
            pose = _shared_pose(rig, board, rng)
            ok = all(fits(c, board, pose) for c in rig.cameras)
        else:
            cam = rig.cameras[(k - n_shared) % 2]
            pose = _close_pose(cam, board, rng)
            ok = fits(cam, board, pose) and pose.t[1] > -0.05
        if ok:
            poses.append(pose)
    return poses


def render_views(poses: list[BoardPose], seed: int = 0, rig: StereoCalibration | None = None,
                 board: BoardSpec = PAPER_BOARD) -> Iterator[tuple[NDArray[np.uint8], ...]]:
    """Yield (side, front) grey images (h, w) uint8 of each pose, with random conditions."""
    rig = rig or paper_rig()
    rng = np.random.default_rng(seed + 1)
    renderers = [BoardRenderer(c, board, seed=seed + i) for i, c in enumerate(rig.cameras)]
    for pose in poses:
        images = []
        for r in renderers:
            box = r.board_bbox(pose.rot, pose.t)
            occl = 0.0 if pose.phase == 'surface' else 0.25
            cond = FrameConditions.random(rng, box, p_occlusion=occl)
            images.append(r.render(pose.rot, pose.t, cond, rng))
        yield tuple(images)


def truth_dict(rig: StereoCalibration, board: BoardSpec,
               poses: list[BoardPose]) -> dict[str, Any]:
    """JSON-ready truth of a twin recording (cameras, board, poses)."""
    return {'rig': rig.to_dict(),
            'board': {'columns': board.columns, 'rows': board.rows,
                      'square_m': board.square_m, 'marker_m': board.marker_m,
                      'dictionary': board.dictionary},
            'poses': [{'rot': p.rot.tolist(), 't': p.t.tolist(), 'phase': p.phase}
                      for p in poses]}


def save_truth(path: str | Path, rig: StereoCalibration, board: BoardSpec,
               poses: list[BoardPose]) -> Path:
    """Write the truth JSON of a twin recording."""
    path = Path(path)
    path.write_text(json.dumps(truth_dict(rig, board, poses), indent=1))
    return path


def synthetic_point_set(n_samples: int, noise_px: float = 0.2, seed: int = 0,
                        rig: StereoCalibration | None = None,
                        board: BoardSpec = PAPER_BOARD) -> PointSet:
    """A paper-size calibration point set without rendering: true corners projected + noise.

    Board poses are drawn in the shared working volume (as ``calibration_poses`` 'shared'),
    every corner inside both images gives one sample, and Gaussian noise of ``noise_px`` (per
    axis) is added to the pixels. ``xyz`` is the exact corner position.

    Args:
        n_samples: number of samples wanted (the paper: 94,939).
        noise_px: corner localisation noise, standard deviation per axis [px].
        seed: random seed.
        rig: true cameras (``paper_rig()`` by default).
        board: the target.

    Returns:
        PointSet of exactly ``n_samples`` rows.
    """
    rig = rig or paper_rig()
    rng = np.random.default_rng(seed)
    obj = board.object_points()
    chunks, total, view = [], 0, 0
    while total < n_samples:
        pose = _shared_pose(rig, board, rng)
        xyz = obj @ pose.rot.T + pose.t
        uv = np.hstack([c.project(xyz) for c in rig.cameras])
        ok = np.all(np.isfinite(uv), axis=1) & np.all(uv >= 0, axis=1) \
            & (uv[:, 0] < rig.side.width) & (uv[:, 2] < rig.front.width) \
            & (uv[:, 1] < rig.side.height) & (uv[:, 3] < rig.front.height)
        uv = uv + noise_px * rng.standard_normal(uv.shape)
        ids = np.flatnonzero(ok)
        chunks.append((uv[ok], xyz[ok], np.full(len(ids), view), ids))
        total += len(ids)
        view += 1
    pix, pts, v, c = (np.concatenate(a)[:n_samples] for a in zip(*chunks, strict=True))
    return make_point_set(pix, pts, v, c)


def project_views(poses: list[BoardPose], noise_px: float = 0.0, seed: int = 0,
                  rig: StereoCalibration | None = None,
                  board: BoardSpec = PAPER_BOARD) -> FloatArray:
    """Ideal detections of each pose without rendering: projected corners plus Gaussian noise.

    Returns:
        (n_poses, 2, n_corners, 2) px, NaN where a corner falls outside an image or the board
        faces away from the camera.
    """
    rig = rig or paper_rig()
    rng = np.random.default_rng(seed)
    obj = board.object_points()
    out = np.full((len(poses), 2, board.n_corners, 2), np.nan)
    for i, pose in enumerate(poses):
        xyz = obj @ pose.rot.T + pose.t
        for c, cam in enumerate(rig.cameras):
            if not fits(cam, board, pose, whole=False, max_incidence_deg=DETECTABLE_DEG):
                continue
            uv = cam.project(xyz) + noise_px * rng.standard_normal((len(obj), 2))
            inside = (uv[:, 0] >= 0) & (uv[:, 0] < cam.width) & (uv[:, 1] >= 0) \
                & (uv[:, 1] < cam.height)
            out[i, c, inside] = uv[inside]
    return out


def smooth_poses(keys: list[BoardPose], steps: int,
                 board: BoardSpec = PAPER_BOARD) -> list[BoardPose]:
    """Board poses moving smoothly through ``keys``: ``steps`` frames per segment.

    Rotation is interpolated on the geodesic, position linearly with smooth-step easing.
    """
    out = []
    mid = board.center_m
    for a, b in pairwise(keys):
        rel = cv2.Rodrigues(b.rot @ a.rot.T)[0].ravel()
        ca, cb = a.t + a.rot @ mid, b.t + b.rot @ mid
        for k in range(steps):
            s = k / steps
            s = s * s * (3 - 2 * s)
            rot = cv2.Rodrigues(rel * s)[0] @ a.rot
            centre = (1 - s) * ca + s * cb
            out.append(BoardPose(rot, centre - rot @ mid, 'moving'))
    return out
