"""The options of one pair of frames: each marker's candidate pairs and rays, with their costs.

For a pair (one detection in each camera near the marker's predicted projections), camera b's
detection is first moved to camera a's stamp by the marker's predicted image motion
(``candidates.shift_to_stamp``: the cameras expose a few ms apart), then the pair is
triangulated; its cost is ``|xyz - predicted|^2 / sigma^2 + (epipolar / EPIPOLAR_SIGMA_PX)^2``
and a pair off the epipolar line by more than the gate is no option at all. For one camera's
ray the cost is ``(d / sigma_px)^2 + RAY_PENALTY`` with d the image distance from the predicted
projection and ``sigma_px`` the prediction's uncertainty seen at that depth plus the
detector's own. Both costs carry the Gaussian's normalisation, ``2 k ln(sigma / SIGMA_REF_M)``
with k the evidence's dimension (3 for a pair, 2 for a ray): a marker whose place is vague (lost
for a while) explains any spot near it only weakly, and must not take a spot from a marker
predicted sharply beside it. Options at or above ``assign.MISS`` are dropped.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.projection import project_points, undistort_normalized
from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import triangulate_pairs
from dempath_recon.tracking.joint3d.assign import MISS, NONE, RAY_PENALTY, Option
from dempath_recon.tracking.joint3d.candidates import (
    PairCandidates,
    pixel_scale,
    shift_to_stamp,
)

FloatArray = NDArray[np.float64]
EPIPOLAR_SIGMA_PX = 1.5  # a right pair's epipolar residual after the stamp shift [px]
DETECTOR_SIGMA_PX = 1.0  # a detection's own error, added to the prediction's in the image [px]
SIGMA_REF_M = 0.0015  # a marker's uncertainty just after a 3D fix (MotionModel.fix_sigma_m) [m]
GATE_SIGMAS = 5.0  # detections farther than this many sigmas from a prediction are no option


class Predictions(NamedTuple):
    """The markers' predicted states in this pair of frames.

    Attributes:
        at_a: (n, 3) positions at camera a's stamp [m].
        at_b: (n, 3) positions at camera b's stamp [m].
        sigma_m: (n,) their uncertainty [m].
    """

    at_a: FloatArray
    at_b: FloatArray
    sigma_m: FloatArray


def pair_options(cams: tuple[Camera, Camera], uv: tuple[FloatArray, FloatArray],
                 cand: PairCandidates, pred: Predictions, epipolar_px: float) -> list[Option]:
    """Every marker's pair options (``cand`` rows near both its predicted projections)."""
    if len(cand.ia) == 0 or len(pred.sigma_m) == 0:
        return []
    sig_px = [pred.sigma_m[:, None] * pixel_scale(c, p)[:, None] + DETECTOR_SIGMA_PX
              for c, p in zip(cams, (pred.at_a, pred.at_b), strict=True)]
    proj_a, proj_b = project_points(cams[0], pred.at_a), project_points(cams[1], pred.at_b)
    da = np.linalg.norm(uv[0][cand.ia][None] - proj_a[:, None], axis=2)  # (n, p)
    db = np.linalg.norm(uv[1][cand.ib][None] - proj_b[:, None], axis=2)
    mi, pj = np.nonzero((da < GATE_SIGMAS * sig_px[0]) & (db < GATE_SIGMAS * sig_px[1]))
    if len(mi) == 0:
        return []
    uv_b = shift_to_stamp(cams[1], uv[1][cand.ib[pj]], pred.at_b[mi], pred.at_a[mi])
    xyz, epi = triangulate_pairs(cams[0], cams[1], uv[0][cand.ia[pj]], uv_b)
    cost = (np.sum((xyz - pred.at_a[mi]) ** 2, axis=1) / pred.sigma_m[mi] ** 2
            + (epi / EPIPOLAR_SIGMA_PX) ** 2 + vagueness(pred.sigma_m[mi], 3))
    keep = (epi < epipolar_px) & (cost < MISS) & np.isfinite(cost)
    return [Option(int(mi[k]), int(cand.ia[pj[k]]), int(cand.ib[pj[k]]), float(cost[k]),
                   xyz[k]) for k in np.flatnonzero(keep)]


def ray_options(cam: Camera, which: int, uv: FloatArray, at: FloatArray, sigma_m: FloatArray,
                ) -> list[Option]:
    """Every marker's options on one camera's rays (``which``: 0 for camera a, 1 for b);
    ``at`` (n, 3) m the predictions at that camera's stamp."""
    if len(uv) == 0 or len(at) == 0:
        return []
    sig_px = sigma_m * pixel_scale(cam, at) + DETECTOR_SIGMA_PX
    d = np.linalg.norm(uv[None] - project_points(cam, at)[:, None], axis=2)  # (n, k)
    cost = (d / sig_px[:, None]) ** 2 + RAY_PENALTY + vagueness(sigma_m, 2)[:, None]
    mi, dj = np.nonzero((cost < MISS) & (d < GATE_SIGMAS * sig_px[:, None]))
    out = []
    for i, j in zip(mi.tolist(), dj.tolist(), strict=True):
        near = nearest_on_ray(cam, uv[j], at[i])
        det_a, det_b = (j, NONE) if which == 0 else (NONE, j)
        out.append(Option(i, det_a, det_b, float(cost[i, j]), near))
    return out


def vagueness(sigma_m: FloatArray, dim: int) -> FloatArray:
    """(n,) the Gaussian's normalisation cost ``2 dim ln(sigma / SIGMA_REF_M)`` (0 for a
    marker placed as sharply as a fresh 3D fix)."""
    return np.asarray(2 * dim * np.log(np.maximum(sigma_m / SIGMA_REF_M, 1.0)), np.float64)


def nearest_on_ray(cam: Camera, uv: FloatArray, xyz: FloatArray) -> FloatArray:
    """(3,) m: the point on the line of sight through ``uv`` (2,) px nearest ``xyz`` (3,) m."""
    xn = undistort_normalized(cam, np.asarray(uv, np.float64).reshape(1, 2))[0]
    rot, t = np.asarray(cam.R, np.float64), np.asarray(cam.t, np.float64)
    centre = -rot.T @ t
    d = rot.T @ np.array([xn[0], xn[1], 1.0])
    s = float((xyz - centre) @ d / (d @ d))
    return np.asarray(centre + max(s, 0.0) * d, np.float64)
