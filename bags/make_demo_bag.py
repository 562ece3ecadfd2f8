"""Make ``bags/demo_two_cams``: a small synthetic two-camera recording of 15 moving markers.

A grid of 15 dark marker spheres (3 rows x 5 columns, 8 mm, as in the paper's 1-15 grid) lies on
a sand surface; a tool travelling along +Z at 1.0 m/s lifts and pushes each marker as it passes.
Two pinhole cameras, cam_side (Cam 1, looking along -X) and cam_front (Cam 2, looking along -Z),
see the scene at 50 FPS. The bag holds per camera ``sensor_msgs/CompressedImage`` JPEG frames
(640x360) on ``/<cam>/image_raw/compressed`` and the exact projected marker pixels as
``dempath_msgs/PixelPoints`` on ``/<cam>/pixel_points`` with the same header stamps.

World frame: X lateral, Y up, Z tool travel, origin on the undisturbed surface [m].

Usage: ``.venv/bin/python bags/make_demo_bag.py [OUT_DIR]`` (default ``bags/demo_two_cams``).
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath import topics
from dempath.bagio import make_typestore, write_bag

WIDTH, HEIGHT, FPS, SECONDS = 640, 360, 50, 2.0
START_NS = 1_700_000_000_000_000_000  # fixed epoch so that the bag is reproducible
MARKER_RADIUS_M = 0.004
TOOL_SPEED_M_S = 1.0
K = np.array([[520.0, 0.0, WIDTH / 2], [0.0, 520.0, HEIGHT / 2], [0.0, 0.0, 1.0]])


def look_at(eye: NDArray[np.float64], target: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
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


def project(camera: str, xyz: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """Pixel positions (n, 2) px and image radii (n,) px of spheres at ``xyz`` (n, 3) m."""
    rot, trans = CAMERAS[camera]
    cam = xyz @ rot.T + trans
    uv = cam[:, :2] / cam[:, 2:3] * K[0, 0] + K[:2, 2]
    return uv, MARKER_RADIUS_M * K[0, 0] / cam[:, 2]


def background(seed: int) -> NDArray[np.uint8]:
    """A sand-coloured (BGR) frame with a smooth gradient and fine, seeded grain."""
    rng = np.random.default_rng(seed)
    rows = np.linspace(0.85, 1.0, HEIGHT)[:, None, None]
    sand = np.array([120.0, 170.0, 200.0]) * rows * np.ones((1, WIDTH, 1))
    grain = cv2.GaussianBlur(rng.normal(0, 6, (HEIGHT, WIDTH)), (0, 0), 1.2)[..., None]
    return np.clip(sand + grain, 0, 255).astype(np.uint8)


def render(camera: str, uv: NDArray, radii: NDArray, base: NDArray[np.uint8]) -> bytes:
    """JPEG bytes of ``base`` with a shaded dark sphere at each pixel position."""
    img = base.copy()
    for (u, v), r in sorted(zip(uv, radii, strict=True), key=lambda p: -p[1]):
        centre, rad = (round(u * 4), round(v * 4)), max(2, round(r * 4))
        cv2.circle(img, centre, rad, (25, 30, 35), -1, cv2.LINE_AA, shift=2)
        cv2.circle(img, (centre[0] - rad // 3, centre[1] - rad // 3), max(1, rad // 3),
                   (90, 95, 100), -1, cv2.LINE_AA, shift=2)
    ok, jpeg = cv2.imencode('.jpg', img, [cv2.IMWRITE_JPEG_QUALITY, 80])
    assert ok, f'{camera}: JPEG encoding failed'
    return jpeg.tobytes()


def messages(store):
    """Yield (topic, msgtype, t_ns, message) for both cameras, frame by frame."""
    types = store.types
    header_t, time_t = types['std_msgs/msg/Header'], types['builtin_interfaces/msg/Time']
    image_t, points_t = types['sensor_msgs/msg/CompressedImage'], \
        types['dempath_msgs/msg/PixelPoints']
    bases = {cam: background(i) for i, cam in enumerate(CAMERAS)}
    ids = np.arange(1, 16, dtype=np.int32)
    for frame in range(int(SECONDS * FPS)):
        t_ns = START_NS + frame * 1_000_000_000 // FPS
        xyz = marker_positions(frame / FPS)
        for cam in CAMERAS:
            header = header_t(stamp=time_t(sec=t_ns // 10**9, nanosec=t_ns % 10**9),
                              frame_id=cam)
            uv, radii = project(cam, xyz)
            jpeg = np.frombuffer(render(cam, uv, radii, bases[cam]), np.uint8)
            yield (topics.camera_topic(topics.IMAGE_COMPRESSED, cam),
                   'sensor_msgs/msg/CompressedImage', t_ns,
                   image_t(header=header, format='jpeg', data=jpeg))
            yield (topics.camera_topic(topics.PIXEL_POINTS, cam), 'dempath_msgs/msg/PixelPoints',
                   t_ns, points_t(header=header, marker_ids=ids,
                                  u=uv[:, 0].copy(), v=uv[:, 1].copy(),
                                  confidence=np.ones(15, np.float32),
                                  source=np.zeros(15, np.uint8)))


def main(argv: list[str]) -> int:
    """Write the demo bag (replacing an old one) and print its size."""
    out = Path(argv[0]) if argv else Path(__file__).resolve().parent / 'demo_two_cams'
    if out.exists():
        shutil.rmtree(out)
    store = make_typestore()
    write_bag(out, messages(store), typestore=store)
    size = sum(p.stat().st_size for p in out.iterdir())
    print(f'{out}: {size / 1e6:.2f} MB')
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
