"""``bags/demo_two_cams``: a small synthetic two-camera recording of 15 moving markers.

A grid of 15 dark marker spheres (3 rows x 5 columns, 8 mm, as in the paper's 1-15 grid) lies on
a sand surface; a tool travelling along +Z at 1.0 m/s lifts and pushes each marker as it passes.
Two pinhole cameras, cam_side (Cam 1, looking along -X) and cam_front (Cam 2, looking along -Z),
see the scene at 50 FPS. The bag holds per camera ``sensor_msgs/CompressedImage`` JPEG frames
(640x360) on ``/<cam>/image_raw/compressed`` and the exact projected marker pixels as
``dempath_msgs/PixelPoints`` on ``/<cam>/pixel_points`` with the same header stamps.

World frame: X lateral, Y up, Z tool travel, origin on the undisturbed surface [m].

SYNTHETIC DATA. Made by ``bags/make_demo_bag.py [OUT_DIR]`` (default ``bags/demo_two_cams``),
which calls :func:`write_two_cams_bag`.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath import topics
from dempath.bagio import write_bag
from dempath.typestore import make_typestore
from dempath_twin.field.markers import background
from dempath_twin.images import jpeg_message, stamp_header

WIDTH, HEIGHT, FPS, SECONDS = 640, 360, 50, 2.0
START_NS = 1_700_000_000_000_000_000  # fixed epoch so that the bag is reproducible
MARKER_RADIUS_M = 0.004
TOOL_SPEED_M_S = 1.0
FloatArray = NDArray[np.float64]
K = np.array([[520.0, 0.0, WIDTH / 2], [0.0, 520.0, HEIGHT / 2], [0.0, 0.0, 1.0]])


def look_at(eye: FloatArray, target: FloatArray) -> tuple[FloatArray, FloatArray]:
    """World->camera rotation and translation of a camera at ``eye`` looking at ``target``."""
    z = (target - eye) / np.linalg.norm(target - eye)
    x = np.cross(z, [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    rot = np.stack([x, y, z])
    return rot, -rot @ eye


CAMERAS = {
    'cam_side': look_at(np.array([0.9, 0.35, 0.3]), np.array([0.0, 0.02, 0.3])),
    'cam_front': look_at(np.array([0.0, 0.45, 1.2]), np.array([0.0, 0.02, 0.3])),
}


def marker_positions(t_s: float) -> NDArray[np.float64]:
    """(15, 3) m positions at time ``t_s``: the grid, lifted and pushed after the tool passes."""
    col, row = np.meshgrid(np.arange(5), np.arange(3))
    x0 = (col.ravel() - 2) * 0.06
    z0 = 0.2 + row.ravel() * 0.08
    tool_z = -0.2 + TOOL_SPEED_M_S * t_s
    since = np.clip((tool_z - z0) / TOOL_SPEED_M_S, 0.0, None)  # s since the tool reached it
    lift = 0.05 * np.exp(-np.abs(x0) / 0.08) * np.sin(np.clip(since * 6.0, 0.0, np.pi))
    push = 0.12 * np.exp(-np.abs(x0) / 0.08) * (1 - np.exp(-since * 4.0))
    side = 0.04 * np.sign(x0) * (1 - np.exp(-since * 4.0))
    return np.stack([x0 + side, MARKER_RADIUS_M + lift, z0 + push], axis=1)


def project(camera: str, xyz: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Pixel positions (n, 2) px and image radii (n,) px of spheres at ``xyz`` (n, 3) m."""
    rot, trans = CAMERAS[camera]
    cam = xyz @ rot.T + trans
    uv = cam[:, :2] / cam[:, 2:3] * K[0, 0] + K[:2, 2]
    return uv, MARKER_RADIUS_M * K[0, 0] / cam[:, 2]


def render(uv: NDArray[np.float64], radii: NDArray[np.float64],
           base: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """``base`` with a shaded dark sphere at each pixel position (far spheres first)."""
    img = base.copy()
    for (u, v), r in sorted(zip(uv, radii, strict=True), key=lambda p: -p[1]):
        centre, rad = (round(u * 4), round(v * 4)), max(2, round(r * 4))
        cv2.circle(img, centre, rad, (25, 30, 35), -1, cv2.LINE_AA, shift=2)
        cv2.circle(img, (centre[0] - rad // 3, centre[1] - rad // 3), max(1, rad // 3),
                   (90, 95, 100), -1, cv2.LINE_AA, shift=2)
    return img


def messages(types: Any) -> Iterator[tuple[str, str, int, Any]]:
    """Yield (topic, msgtype, t_ns, message) for both cameras, frame by frame."""
    points_t = types['dempath_msgs/msg/PixelPoints']
    bases = {cam: background(WIDTH, HEIGHT, i) for i, cam in enumerate(CAMERAS)}
    ids = np.arange(1, 16, dtype=np.int32)
    for frame in range(int(SECONDS * FPS)):
        t_ns = START_NS + frame * 1_000_000_000 // FPS
        xyz = marker_positions(frame / FPS)
        for cam in CAMERAS:
            header = stamp_header(types, t_ns, cam)
            uv, radii = project(cam, xyz)
            yield (topics.camera_topic(topics.IMAGE_COMPRESSED, cam),
                   'sensor_msgs/msg/CompressedImage', t_ns,
                   jpeg_message(types, header, render(uv, radii, bases[cam]), 80, 'jpeg'))
            yield (topics.camera_topic(topics.PIXEL_POINTS, cam), 'dempath_msgs/msg/PixelPoints',
                   t_ns, points_t(header=header, marker_ids=ids,
                                  u=uv[:, 0].copy(), v=uv[:, 1].copy(),
                                  confidence=np.ones(15, np.float32),
                                  source=np.zeros(15, np.uint8)))


def write_two_cams_bag(out: Path) -> Path:
    """Write the bag to ``out`` (replacing an old one) and return it."""
    if out.exists():
        shutil.rmtree(out)
    store = make_typestore()
    write_bag(out, messages(store.types), typestore=store)
    return out
