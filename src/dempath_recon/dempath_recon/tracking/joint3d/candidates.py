"""Candidate 3D points of one pair of frames: every cross-camera pair of detections near each
other's epipolar line, triangulated.

The two cameras expose a few milliseconds apart (the twin's front camera 3 ms after the side
one), so a marker moving at 1 m/s is seen a few millimetres apart by the two: a pair is
gated loosely here (``gate_px`` includes that motion) and judged per marker in the assignment,
after its second view is moved to the first one's stamp (``shift_to_stamp``). Distances to the
epipolar line are in undistorted pixels of the second camera (Hartley & Zisserman, Multiple
View Geometry, 2nd ed., sec. 9.2).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.projection import project_points
from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import epipolar_distance, triangulate_pairs

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.intp]


class PairCandidates(NamedTuple):
    """Cross-camera pairs of one pair of frames.

    Attributes:
        ia: (p,) index of each pair's detection in camera a.
        ib: (p,) index of each pair's detection in camera b.
        epipolar_px: (p,) distance of b's detection from a's epipolar line [px of b].
        xyz: (p, 3) the pair triangulated (world frame) [m].
    """

    ia: IndexArray
    ib: IndexArray
    epipolar_px: FloatArray
    xyz: FloatArray

    @classmethod
    def empty(cls) -> PairCandidates:
        """No pair."""
        return cls(np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0), np.zeros((0, 3)))


def pair_candidates(cam_a: Camera, cam_b: Camera, uv_a: FloatArray, uv_b: FloatArray,
                    gate_px: float) -> PairCandidates:
    """All pairs of detections ``uv_a`` (n, 2) px and ``uv_b`` (k, 2) px whose distance from
    each other's epipolar line is below ``gate_px`` [px of b], triangulated; pairs whose point
    lies behind either camera are dropped (two lines of sight that meet behind the cameras)."""
    if len(uv_a) == 0 or len(uv_b) == 0:
        return PairCandidates.empty()
    d = epipolar_distance(cam_a, cam_b, uv_a, uv_b)
    ia, ib = np.nonzero(d < gate_px)
    if len(ia) == 0:
        return PairCandidates.empty()
    xyz, epi = triangulate_pairs(cam_a, cam_b, uv_a[ia], uv_b[ib])
    front = np.isfinite(xyz).all(axis=1) & in_front(cam_a, xyz) & in_front(cam_b, xyz)
    return PairCandidates(ia[front].astype(np.intp), ib[front].astype(np.intp), epi[front],
                          xyz[front])


def in_front(cam: Camera, xyz: FloatArray) -> NDArray[np.bool_]:
    """(n,) whether each world point (n, 3) m lies in front of the camera (positive depth)."""
    local = xyz @ np.asarray(cam.R, np.float64).T + np.asarray(cam.t, np.float64)
    return np.asarray(local[:, 2] > 0, np.bool_)


def shift_to_stamp(cam_b: Camera, uv_b: FloatArray, at_b: FloatArray,
                   at_a: FloatArray) -> FloatArray:
    """(n, 2) px: detections ``uv_b`` of camera b moved by the image motion of their markers
    between b's stamp and a's: ``project(at_a) - project(at_b)``, with ``at_a``, ``at_b``
    (n, 3) m each marker's predicted position at the two stamps."""
    moved = project_points(cam_b, at_a) - project_points(cam_b, at_b)
    return np.asarray(uv_b + moved, np.float64)


def pixel_scale(cam: Camera, xyz: FloatArray) -> FloatArray:
    """(n,) pixels per metre across the line of sight at each world point (n, 3) m
    (``f / depth``): turns a 3D uncertainty into one in the image."""
    local = xyz @ np.asarray(cam.R, np.float64).T + np.asarray(cam.t, np.float64)
    f = 0.5 * float(np.asarray(cam.K)[0, 0] + np.asarray(cam.K)[1, 1])
    return np.asarray(f / np.maximum(local[:, 2], 1e-3), np.float64)
