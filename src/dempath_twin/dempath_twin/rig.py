"""The digital twin of the paper's two-camera rig: true cameras and the working volume.

Intrinsics are the ones measured in the paper (Technologies 2025, 13, 570, section on camera
calibration): Cam 1 (side) fx 914.24, fy 922.16, cx 952.56, cy 548.95, k1 -0.01, k2 0.04,
k3 -0.05; Cam 2 (front) fx 917.17, fy 920.53, cx 952.74, cy 555.56, k1 0.01, k2 -0.02, k3 0.02;
p1 = p2 = 0; 1920x1080 px. The poses are ours (plausible, not from the paper):

- world frame: X lateral, Y vertical up, Z direction of tool travel, origin at the centre of the
  reference ChArUco board laid on the undisturbed sand surface (the board's rows run along +Z);
- working volume (where the tracked markers move): X -0.2..0.2 m, Y -0.1..0.15 m,
  Z -0.25..0.25 m;
- side camera at (0.75, 0.45, 0.0) m, across the channel, looking at the origin (about 0.87 m);
- front camera at (0.0, 0.45, 0.80) m, ahead of the tool, looking back along -Z at the origin
  (about 0.92 m).

That fixed rig (:func:`paper_rig`) is what the board point set, the shipped MLP and the clicked
field twins were made with. The paper mounts both GoPros on the supporting frame of the
movable carriage (its Figure 3: Cam 1 at the side, Cam 2 at the front, looking down at the
1-15 marker grid); it gives no distances or angles, so :func:`carriage_rig`'s placement is
ours: the side camera 1.10 m above the sand and 0.30 m to the side of the grid (75 deg down),
the front camera 1.00 m up and 0.45 m ahead of the grid centre on the tool's axis (66 deg
down), both aimed 3 cm ahead of the grid centre; 28 deg between the two lines of sight, the
8 mm markers 6-7 px across. It was chosen among 18 side and 18 front placements on the demo's
hidden run by the markers both cameras see over the frames in which they are on the surface
(:mod:`dempath_twin.render.coverage`; bench/marker_coverage.py): 15 of 15 in at least 80 %
of them (the placement of session 12, 0.75 m up and 57-59 deg down, 10 of 15 over all
frames). Seen from 30 deg above the surface (the fixed rig), a clay marker half sunk among
the grains and the heave beside the tool hide most markers from one camera or the other. The
rendered field recording uses the carriage rig; it carries its own board views, so the demo
calibrates it as a user would.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_calib.camera import CameraModel, StereoCalibration

FloatArray = NDArray[np.float64]

IMAGE_SIZE = (1920, 1080)  # (width, height) px of both GoPros in linear mode
WORKING_VOLUME = np.array([[-0.20, -0.10, -0.25], [0.20, 0.15, 0.25]])  # (min, max) xyz [m]

SIDE_INTRINSICS = {'fx': 914.24, 'fy': 922.16, 'cx': 952.56, 'cy': 548.95,
                   'k1': -0.01, 'k2': 0.04, 'p1': 0.0, 'p2': 0.0, 'k3': -0.05}
FRONT_INTRINSICS = {'fx': 917.17, 'fy': 920.53, 'cx': 952.74, 'cy': 555.56,
                    'k1': 0.01, 'k2': -0.02, 'p1': 0.0, 'p2': 0.0, 'k3': 0.02}
SIDE_CENTER = (0.75, 0.45, 0.0)  # m, world frame
FRONT_CENTER = (0.0, 0.45, 0.80)  # m, world frame
LOOK_AT = (0.0, 0.0, 0.0)  # m, both cameras aim at the origin on the sand surface
CARRIAGE_SIDE_CENTER = (0.30, 1.10, 0.0)  # m: side beam of the carriage frame, 75 deg down
CARRIAGE_FRONT_CENTER = (0.0, 1.00, 0.45)  # m: front beam, ahead of the tool, 66 deg down
CARRIAGE_LOOK_AT = (0.0, 0.0, 0.03)  # m: a little ahead of the grid centre (markers move +Z)


def look_at(center: FloatArray, target: FloatArray,
            up: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """World->camera pose of a camera at ``center`` looking at ``target`` with image-up ~ ``up``.

    Args:
        center: (3,) camera centre in the world frame [m].
        target: (3,) point on the optical axis [m].
        up: (3,) world direction that should appear up in the image (default +Y).

    Returns:
        ``(R, t)``: (3, 3) rotation and (3,) translation [m], ``x_cam = R X + t``.
    """
    c = np.asarray(center, dtype=np.float64)
    up_vec = np.array([0.0, 1.0, 0.0]) if up is None else np.asarray(up, dtype=np.float64)
    z = np.asarray(target, dtype=np.float64) - c
    z /= np.linalg.norm(z)
    x = np.cross(z, up_vec)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    rot = np.vstack([x, y, z])
    return rot, -rot @ c


def intrinsic_matrix(p: dict[str, float]) -> FloatArray:
    """(3, 3) K [px] from a dict with fx, fy, cx, cy."""
    return np.array([[p['fx'], 0.0, p['cx']], [0.0, p['fy'], p['cy']], [0.0, 0.0, 1.0]])


def distortion(p: dict[str, float]) -> FloatArray:
    """(5,) distortion k1, k2, p1, p2, k3 (OpenCV order) from a dict."""
    return np.array([p['k1'], p['k2'], p['p1'], p['p2'], p['k3']])


def paper_rig() -> StereoCalibration:
    """The twin's fixed true cameras: side (Cam 1) and front (Cam 2), in the world frame above."""
    return _rig(SIDE_CENTER, FRONT_CENTER, 'dempath_twin.rig.paper_rig')


def carriage_rig() -> StereoCalibration:
    """The paper's GoPros on the carriage frame, looking down at the marker grid (see above)."""
    return _rig(CARRIAGE_SIDE_CENTER, CARRIAGE_FRONT_CENTER, 'dempath_twin.rig.carriage_rig',
                CARRIAGE_LOOK_AT)


RIGS = {'carriage': carriage_rig, 'fixed': paper_rig}  # by the name the render CLI takes


def _rig(side: tuple[float, float, float], front: tuple[float, float, float],
         source: str, target: tuple[float, float, float] = LOOK_AT) -> StereoCalibration:
    cams = []
    for name, intr, center in (('cam_side', SIDE_INTRINSICS, side),
                               ('cam_front', FRONT_INTRINSICS, front)):
        rot, t = look_at(np.array(center), np.array(target))
        cams.append(CameraModel(name, IMAGE_SIZE[0], IMAGE_SIZE[1], intrinsic_matrix(intr),
                                distortion(intr), rot, t))
    return StereoCalibration(cams[0], cams[1], {'source': source})


def sample_working_volume(n: int, rng: np.random.Generator) -> FloatArray:
    """(n, 3) points drawn uniformly in the working volume [m]."""
    lo, hi = WORKING_VOLUME
    return np.asarray(lo + (hi - lo) * rng.random((n, 3)), np.float64)
