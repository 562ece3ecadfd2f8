"""Geometrically exact rendering of a planar board into a distorted camera (the twin's images).

For every output pixel (u, v) the renderer knows the ideal (undistorted) pixel it images, found
once per camera by inverting OpenCV's distortion model (``cv2.undistortPointsIter``); a plane
homography takes the ideal pixel to the board texture, and one ``cv2.remap`` samples it. So the
image of a board point X lands exactly at ``camera.project(X)``, up to interpolation of a texture
of 120 px per square. Realism on top (all seeded): sand background, lighting gain and gradient,
partial occlusion by a hand-like blob, Gaussian and motion blur, read and shot noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_calib.board import BoardSpec
from dempath_calib.camera import CameraModel

FloatArray = NDArray[np.float64]
TEXTURE_PX_PER_SQUARE = 120  # board texture resolution (about 3 px/mm for 40.4 mm squares)
TEXTURE_MARGIN_SQUARES = 0.5  # white margin around the chessboard, in squares
WHITE, BLACK = 0.85, 0.06  # albedo of the printed board


@dataclass(frozen=True)
class FrameConditions:
    """Imaging conditions of one rendered frame.

    Attributes:
        gain: overall illumination [-] (1 = nominal).
        gradient: (gx, gy) relative illumination change across the image width/height [-].
        blur_sigma_px: Gaussian blur (defocus) [px].
        motion_px: length of a linear motion blur [px] (0 = none).
        motion_angle_rad: direction of the motion blur [rad].
        noise_dn: read noise [grey levels]; shot noise is added on top.
        occlusion: (cx, cy, ax, ay) of an occluding ellipse in px, or None.
    """

    gain: float = 1.0
    gradient: tuple[float, float] = (0.0, 0.0)
    blur_sigma_px: float = 0.7
    motion_px: float = 0.0
    motion_angle_rad: float = 0.0
    noise_dn: float = 1.5
    occlusion: tuple[float, float, float, float] | None = None

    @classmethod
    def random(cls, rng: np.random.Generator, occlusion_box: FloatArray | None = None,
               p_occlusion: float = 0.2, p_motion: float = 0.3) -> FrameConditions:
        """Draw realistic conditions; ``occlusion_box`` (4,) px x0 y0 x1 y1 places the blob."""
        occ = None
        if occlusion_box is not None and rng.random() < p_occlusion:
            x0, y0, x1, y1 = occlusion_box
            edge = rng.integers(4)  # the hand comes in from one side of the board
            cx = [x0, x1, rng.uniform(x0, x1), rng.uniform(x0, x1)][edge]
            cy = [rng.uniform(y0, y1), rng.uniform(y0, y1), y0, y1][edge]
            size = 0.25 * max(x1 - x0, y1 - y0)
            occ = (float(cx), float(cy), float(size * rng.uniform(0.6, 1.0)),
                   float(size * rng.uniform(0.3, 0.6)))
        motion = float(rng.uniform(1.5, 3.5)) if rng.random() < p_motion else 0.0
        return cls(gain=float(rng.uniform(0.7, 1.15)),
                   gradient=(float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-0.3, 0.3))),
                   blur_sigma_px=float(rng.uniform(0.5, 1.2)), motion_px=motion,
                   motion_angle_rad=float(rng.uniform(0, np.pi)),
                   noise_dn=float(rng.uniform(1.0, 2.5)), occlusion=occ)


def board_texture(board: BoardSpec) -> tuple[NDArray[np.float32], FloatArray]:
    """Albedo image of the board and the affine map texture px -> board metres.

    Returns:
        ``(texture, A)``: (h, w) float32 albedo, and (3, 3) A with
        ``[x_m, y_m, 1] = A @ [col, row, 1]`` for texture pixel centres.
    """
    s = TEXTURE_PX_PER_SQUARE
    margin = round(TEXTURE_MARGIN_SQUARES * s)
    size = (board.columns * s + 2 * margin, board.rows * s + 2 * margin)
    if board.kind.value == 'charuco':
        img = board.cv_board.generateImage(size, marginSize=margin, borderBits=1)
    else:  # plain chessboard
        img = np.full(size[::-1], 255, np.uint8)
        for r in range(board.rows):
            for c in range((r % 2), board.columns, 2):
                img[margin + r * s:margin + (r + 1) * s, margin + c * s:margin + (c + 1) * s] = 0
    albedo = BLACK + (WHITE - BLACK) * (img.astype(np.float32) / 255.0)
    if board.inverted:
        albedo = (WHITE + BLACK) - albedo
    albedo = cv2.GaussianBlur(albedo, (0, 0), 0.8)  # anti-aliasing before minification
    k = board.square_m / s
    a = np.array([[k, 0.0, (0.5 - margin) * k], [0.0, k, (0.5 - margin) * k], [0, 0, 1.0]])
    return albedo, a


class BoardRenderer:
    """Renders a board into one camera.

    Args:
        camera: the true camera (K, dist, pose).
        board: the target.
        seed: seed of the camera's static sand background.
    """

    def __init__(self, camera: CameraModel, board: BoardSpec, seed: int = 0) -> None:
        self.camera = camera
        self.board = board
        self.texture, self._tex_to_board = board_texture(board)
        u, v = np.meshgrid(np.arange(camera.width, dtype=np.float64),
                           np.arange(camera.height, dtype=np.float64))
        ideal = camera.undistort_points(np.column_stack([u.ravel(), v.ravel()]))
        self._ideal = ideal.reshape(camera.height, camera.width, 2)
        self.background = _sand(camera.height, camera.width, np.random.default_rng(seed))
        self._outline = self._board_outline()

    def _board_outline(self) -> FloatArray:
        """(4, 3) outer corners of the printed sheet in the board frame [m]."""
        w, h = self.board.size_m
        m = TEXTURE_MARGIN_SQUARES * self.board.square_m
        return np.array([[-m, -m, 0], [w + m, -m, 0], [w + m, h + m, 0], [-m, h + m, 0]])

    def board_bbox(self, rot: FloatArray, t: FloatArray) -> FloatArray | None:
        """(4,) px x0 y0 x1 y1 of the sheet in the image (clipped), or None if not visible."""
        world = self._outline @ rot.T + t
        if np.any(self.camera.to_camera(world)[:, 2] <= 0.05):
            return None
        uv = self.camera.project(world)
        x0, y0 = np.floor(uv.min(0)) - 4
        x1, y1 = np.ceil(uv.max(0)) + 4
        x0, y0 = max(x0, 0), max(y0, 0)
        x1, y1 = min(x1, self.camera.width), min(y1, self.camera.height)
        if x1 <= x0 or y1 <= y0:
            return None
        return np.array([x0, y0, x1, y1])

    def render(self, rot: FloatArray, t: FloatArray, cond: FrameConditions,
               rng: np.random.Generator) -> NDArray[np.uint8]:
        """One grey image (h, w) uint8 of the board at pose ``X_world = rot @ p_board + t``."""
        radiance = self.background.copy()
        box = self.board_bbox(rot, t)
        if box is not None:
            self._paste_board(radiance, rot, t, box)
        if cond.occlusion is not None:
            cx, cy, ax, ay = cond.occlusion
            cv2.ellipse(radiance, (round(cx), round(cy)), (round(ax), round(ay)),
                        float(np.degrees(cond.motion_angle_rad)), 0, 360, 0.25, -1)
        return _expose(radiance, cond, rng)

    def _paste_board(self, radiance: NDArray[np.float32], rot: FloatArray, t: FloatArray,
                     box: FloatArray) -> None:
        x0, y0, x1, y1 = (int(b) for b in box)
        cam = self.camera
        r_cb = cam.R @ rot
        t_cb = cam.R @ t + cam.t
        h = cam.K @ np.column_stack([r_cb[:, 0], r_cb[:, 1], t_cb])
        g = np.linalg.inv(h @ self._tex_to_board)
        ideal = self._ideal[y0:y1, x0:x1]
        den = g[2, 0] * ideal[..., 0] + g[2, 1] * ideal[..., 1] + g[2, 2]
        mx = (g[0, 0] * ideal[..., 0] + g[0, 1] * ideal[..., 1] + g[0, 2]) / den
        my = (g[1, 0] * ideal[..., 0] + g[1, 1] * ideal[..., 1] + g[1, 2]) / den
        mx, my = mx.astype(np.float32), my.astype(np.float32)
        tex = cv2.remap(self.texture, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                        borderValue=0.0)
        alpha = cv2.remap(np.ones_like(self.texture), mx, my, cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)
        roi = radiance[y0:y1, x0:x1]
        roi[:] = alpha * tex + (1 - alpha) * roi


def _sand(h: int, w: int, rng: np.random.Generator) -> NDArray[np.float32]:
    """(h, w) float32 albedo of a sand-like background: blotches plus grain."""
    coarse = cv2.resize(rng.random((h // 32 + 1, w // 32 + 1)).astype(np.float32), (w, h),
                        interpolation=cv2.INTER_CUBIC)
    grain = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 1.0)
    return (0.35 + 0.15 * coarse + 0.25 * (grain - 0.5)).astype(np.float32)


def _expose(radiance: NDArray[np.float32], cond: FrameConditions,
            rng: np.random.Generator) -> NDArray[np.uint8]:
    """Lighting, blur and sensor noise: radiance (h, w) -> 8-bit image."""
    h, w = radiance.shape
    gx, gy = cond.gradient
    light = cond.gain * (1 + gx * (np.arange(w, dtype=np.float32) / w - 0.5))[None, :] \
        * (1 + gy * (np.arange(h, dtype=np.float32) / h - 0.5))[:, None]
    img = 235.0 * radiance * light
    img = np.asarray(cv2.GaussianBlur(img, (0, 0), cond.blur_sigma_px), np.float32)
    if cond.motion_px > 0:
        n = int(np.ceil(cond.motion_px)) | 1
        kernel = np.zeros((n, n), np.float32)
        c = n // 2
        dx, dy = np.cos(cond.motion_angle_rad) * c, np.sin(cond.motion_angle_rad) * c
        cv2.line(kernel, (round(c - dx), round(c - dy)), (round(c + dx), round(c + dy)), 1.0)
        img = np.asarray(cv2.filter2D(img, -1, kernel / kernel.sum()), np.float32)
    sigma = np.sqrt(cond.noise_dn ** 2 + 0.05 * np.maximum(img, 0))
    img = img + sigma * rng.standard_normal(img.shape, dtype=np.float32)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)
