"""What one camera of the twin rig sees of the simulated bed: a shaded, distorted colour frame.

Every sphere of the bed and the tool's triangles are depth-tested into an ideal pinhole image
(``splat``) at ``supersample`` times the sensor's resolution; each pixel is shaded from a
directional light with an ambient term (Lambert) and a shadow map, sand grains get their own
albedo and a texture, the marker spheres a clay colour that contrasts with sand, the steel tool
a specular highlight. The ideal image is box-filtered to the sensor's pitch (anti-aliasing) and
mapped through the camera's lens distortion with one ``cv2.remap`` (the ideal position of every
sensor pixel comes from inverting OpenCV's model once, as the board renderer does), so a point
X images exactly at ``camera.project(X)``. Motion blur averages sub-frames spread over the
exposure; lighting gain, a gradient, read and shot noise are added last.

Colours are BGR albedos in 0..1; images are 8-bit BGR.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_twin.render.splat import (
    NO_HIT,
    light_frame,
    lookup_shadow,
    raster_shadow_triangles,
    raster_triangles,
    splat_shadow,
    splat_spheres,
)

FloatArray = NDArray[np.float64]
SAND_BGR = (0.42, 0.58, 0.72)  # dry quartz sand albedo, yellow-brown
CLAY_BGR = (0.62, 0.22, 0.10)  # blue modelling clay: opposite to sand in the Cb-Cr plane
STEEL_BGR = (0.50, 0.50, 0.52)  # the tool
SHADOW_CELL_M = 0.002  # shadow-map cell [m]
SHADOW_BIAS_M = 0.003  # depth tolerance of the shadow test [m] (avoids self-shadowing)


@dataclass(frozen=True)
class Look:
    """Appearance settings of a rendered field recording.

    Attributes:
        supersample: ideal-image samples per sensor pixel along each axis (anti-aliasing).
        marker_diameter_m: diameter of the clay marker spheres [m] (the paper: about 8 mm).
        grain_spread: relative spread of the grains' albedo [-].
        ambient: share of light that reaches shadowed and turned-away surfaces [-].
        noise_dn: read noise [grey levels]; shot noise is added on top.
        blur_subframes: sub-frames averaged over the exposure (1 = no motion blur).
        exposure_s: exposure time [s] (motion blur length = speed x exposure).
        light: light level relative to the default scene (scales the exposure; the shot
            noise follows the signal) [-].
        sand_bgr: mean albedo of the sand grains (B, G, R).
        marker_bgr: albedo of the clay markers (B, G, R).
        flicker: the light's change from frame to frame: each frame's light times ``1 + f u``,
            ``u`` uniform in [-1, 1] (a lamp beating against the frame rate, a sun through
            blown dust) [-]; 0: none.
        cloud: the light's lowest level while a cloud passes, relative [-]: the light falls
            to it at the middle of the pass and recovers by its end (a raised cosine over
            the recording); 1: no cloud.
    """

    supersample: int = 2
    marker_diameter_m: float = 0.008
    grain_spread: float = 0.12
    ambient: float = 0.35
    noise_dn: float = 2.0
    blur_subframes: int = 3
    exposure_s: float = 0.004
    light: float = 1.0
    sand_bgr: tuple[float, float, float] = SAND_BGR
    marker_bgr: tuple[float, float, float] = CLAY_BGR
    flicker: float = 0.0
    cloud: float = 1.0

    def __post_init__(self) -> None:
        checks = {'supersample': 1 <= self.supersample <= 4,
                  'marker_diameter_m': 0 < self.marker_diameter_m < 0.1,
                  'grain_spread': 0 <= self.grain_spread < 0.5, 'ambient': 0 <= self.ambient <= 1,
                  'noise_dn': self.noise_dn >= 0, 'blur_subframes': self.blur_subframes >= 1,
                  'exposure_s': 0 <= self.exposure_s <= 0.02, 'light': 0 < self.light <= 10,
                  'sand_bgr': all(0 < c < 1 for c in self.sand_bgr),
                  'marker_bgr': all(0 < c < 1 for c in self.marker_bgr),
                  'flicker': 0 <= self.flicker < 1, 'cloud': 0 < self.cloud <= 1}
        for name, ok in checks.items():
            if not ok:
                msg = f'{name}: out of range, got {getattr(self, name)!r}'
                raise ValueError(msg)


@dataclass(frozen=True)
class Light:
    """Illumination of one frame: ``direction`` (3,) towards the sun (world), ``gain``, and
    ``gradient`` (gx, gy), the relative change across the image width and height."""

    direction: tuple[float, float, float] = (0.3, 1.0, -0.4)
    gain: float = 1.0
    gradient: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class Scene3D:
    """What is in front of the cameras at one instant (world frame of the cameras, metres).

    Attributes:
        centres: (n, 3) sphere centres; NaN rows are not drawn.
        radii: (n,) radii.
        albedo: (n, 3) BGR albedo per sphere.
        texture: (n,) texture phase per sphere [rad].
        tool: (k, 3, 3) tool triangles, or (0, 3, 3).
    """

    centres: FloatArray
    radii: FloatArray
    albedo: NDArray[np.float32]
    texture: NDArray[np.float32]
    tool: FloatArray


def scaled_camera(camera: Any, scale: float) -> Any:
    """``camera`` (dempath_calib CameraModel) with a sensor ``scale`` times as large (tests)."""
    k = camera.K.copy()
    k[:2] *= scale
    k[0, 2] = (camera.K[0, 2] + 0.5) * scale - 0.5
    k[1, 2] = (camera.K[1, 2] + 0.5) * scale - 0.5
    return replace(camera, width=round(camera.width * scale),
                   height=round(camera.height * scale), K=k)


class FieldCamera:
    """Renders the bed into one camera.

    Args:
        camera: the camera (dempath_calib CameraModel: K, dist, R, t, width, height).
        look: appearance settings.
        seed: seed of the static background.
    """

    def __init__(self, camera: Any, look: Look, seed: int = 0) -> None:
        self.camera, self.look = camera, look
        u, v = np.meshgrid(np.arange(camera.width, dtype=np.float64),
                           np.arange(camera.height, dtype=np.float64))
        pix = np.column_stack([u.ravel(), v.ravel()])
        ideal = camera.undistort_points(pix)
        valid = _round_trip(camera, ideal, pix)
        self.origin = np.floor(ideal[valid].min(0)) - 2  # (ox, oy) ideal px
        size = np.ceil(ideal[valid].max(0) - self.origin).astype(int) + 3
        self.ideal_size = (int(size[0]), int(size[1]))  # (w, h) of the 1x ideal image
        ideal[~valid] = -1e4  # where OpenCV's model cannot be inverted: nothing (black)
        ideal = ideal.reshape(camera.height, camera.width, 2)
        self.map_x = (ideal[..., 0] - self.origin[0]).astype(np.float32)
        self.map_y = (ideal[..., 1] - self.origin[1]).astype(np.float32)
        self.background = _ground(self.ideal_size, np.random.default_rng(seed))
        ss = look.supersample
        k = camera.K
        self.intr = np.array([k[0, 0] * ss, k[1, 1] * ss,
                              (k[0, 2] - self.origin[0] + 0.5) * ss - 0.5,
                              (k[1, 2] - self.origin[1] + 0.5) * ss - 0.5, 0.0, 0.0])

    def buffers(self, scene: Scene3D) -> tuple[NDArray[np.float32], NDArray[np.int32],
                                               NDArray[np.float32]]:
        """Depth (h, w) m, index (h, w) (n = the tool, -1 nothing) and normals (h, w, 3)."""
        ss = self.look.supersample
        w, h = self.ideal_size[0] * ss, self.ideal_size[1] * ss
        zbuf = np.full((h, w), np.inf, np.float32)
        ibuf = np.full((h, w), NO_HIT, np.int32)
        nbuf = np.zeros((h, w, 3), np.float32)
        cam = self.camera
        centres = np.ascontiguousarray(scene.centres @ cam.R.T + cam.t)
        splat_spheres(centres, np.ascontiguousarray(scene.radii, np.float64), self.intr, zbuf,
                      ibuf, nbuf)
        if len(scene.tool):
            tris = np.ascontiguousarray(scene.tool @ cam.R.T + cam.t)
            raster_triangles(tris, self.intr, len(scene.radii), zbuf, ibuf, nbuf)
        return zbuf, ibuf, nbuf

    def radiance(self, scene: Scene3D, light: Light, shadow: ShadowMap,
                 ) -> tuple[NDArray[np.float32], NDArray[np.int32]]:
        """Shaded ideal image (h, w, 3) at 1x and the supersampled index buffer."""
        zbuf, ibuf, nbuf = self.buffers(scene)
        hit = ibuf >= 0
        rows, cols = np.nonzero(hit)
        idx = ibuf[rows, cols]
        normal = nbuf[rows, cols]
        cam = self.camera
        to_light = cam.R @ (np.asarray(light.direction) / np.linalg.norm(light.direction))
        lambert = np.clip(normal @ to_light.astype(np.float32), 0.0, 1.0)
        ray = np.column_stack([(cols - self.intr[2]) / self.intr[0],
                               (rows - self.intr[3]) / self.intr[1], np.ones(len(rows))])
        world = ((ray * zbuf[rows, cols, None]) - cam.t) @ cam.R
        lit = shadow.lit(world)
        n_spheres = len(scene.radii)
        is_tool = idx == n_spheres
        albedo = np.empty((len(idx), 3), np.float32)
        sph = ~is_tool
        albedo[sph] = scene.albedo[idx[sph]]
        albedo[is_tool] = STEEL_BGR
        phase = scene.texture[np.minimum(idx, n_spheres - 1)]
        texture = 1.0 + 0.5 * self.look.grain_spread * np.sin(
            9.0 * normal[:, 0] + 7.0 * normal[:, 1] + phase)
        texture[is_tool] = 1.0
        amb = self.look.ambient
        shade = (amb + (1 - amb) * lambert * lit) * texture
        out = albedo * shade[:, None]
        half = to_light.astype(np.float32) - np.array([0, 0, 1], np.float32)
        half /= np.linalg.norm(half)
        spec = np.clip(normal[is_tool] @ half, 0, 1) ** 30 * lit[is_tool]
        out[is_tool] += 0.6 * spec[:, None]
        ss = self.look.supersample
        big = np.zeros((*ibuf.shape, 3), np.float32)
        cover = np.zeros(ibuf.shape, np.float32)
        big[rows, cols] = out * light.gain
        cover[rows, cols] = 1.0
        size = self.ideal_size
        small = cv2.resize(big, size, interpolation=cv2.INTER_AREA) if ss > 1 else big
        alpha = cv2.resize(cover, size, interpolation=cv2.INTER_AREA) if ss > 1 else cover
        small += (1.0 - alpha)[..., None] * self.background * light.gain
        return np.asarray(small, np.float32), ibuf

    def expose(self, ideal: NDArray[np.float32], light: Light,
               rng: np.random.Generator) -> NDArray[np.uint8]:
        """Distort, add the lighting gradient and sensor noise: ideal radiance -> 8-bit BGR."""
        img = cv2.remap(ideal, self.map_x, self.map_y, cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        h, w = img.shape[:2]
        gx, gy = light.gradient
        ramp = (1 + gx * (np.arange(w, dtype=np.float32) / w - 0.5))[None, :] \
            * (1 + gy * (np.arange(h, dtype=np.float32) / h - 0.5))[:, None]
        img = 255.0 * self.look.light * img * ramp[..., None]
        sigma = np.sqrt(self.look.noise_dn ** 2 + 0.05 * np.maximum(img, 0))
        img = img + sigma * rng.standard_normal(img.shape, dtype=np.float32)
        return np.asarray(np.clip(np.rint(img), 0, 255), np.uint8)

    def visible_fraction(self, ibuf: NDArray[np.int32], scene: Scene3D,
                         index: NDArray[np.int64]) -> FloatArray:
        """(m,) share of each sphere ``index`` (m,) whose disc is not hidden, 0..1."""
        cam = self.camera
        counts = np.bincount(ibuf[ibuf >= 0].ravel(), minlength=len(scene.radii) + 1)
        centres = scene.centres[index] @ cam.R.T + cam.t
        z = centres[:, 2]
        area = np.pi * (self.intr[0] * scene.radii[index] / z) \
            * (self.intr[1] * scene.radii[index] / z)
        frac = np.where((z > 0) & np.isfinite(z), counts[index] / np.maximum(area, 1e-9), 0.0)
        return np.asarray(np.clip(frac, 0.0, 1.0), np.float64)


class ShadowMap:
    """Orthographic depth map from the light over the bed (what is lit, what is in shadow).

    Args:
        scene: what casts shadows.
        direction: (3,) towards the light, world frame.
    """

    def __init__(self, scene: Scene3D, direction: tuple[float, float, float]) -> None:
        self.frame = light_frame(np.asarray(direction, np.float64))
        finite = np.all(np.isfinite(scene.centres), axis=1)
        pts = scene.centres[finite] @ self.frame.T
        tool = scene.tool @ self.frame.T if len(scene.tool) else np.zeros((0, 3, 3))
        ext = np.vstack([pts[:, :2], tool.reshape(-1, 3)[:, :2]]) if len(pts) else \
            np.zeros((1, 2))
        lo, hi = ext.min(0) - 0.02, ext.max(0) + 0.02
        cells = np.minimum(np.ceil((hi - lo) / SHADOW_CELL_M).astype(int) + 1, 4000)
        cell = float(max((hi - lo).max() / 4000, SHADOW_CELL_M))
        self.grid = np.array([lo[0], lo[1], cell])
        self.map = np.full((int(cells[1]), int(cells[0])), np.inf, np.float32)
        splat_shadow(np.ascontiguousarray(pts), np.ascontiguousarray(scene.radii[finite]),
                     self.grid, self.map)
        if len(tool):
            raster_shadow_triangles(np.ascontiguousarray(tool), self.grid, self.map)

    def lit(self, world: FloatArray) -> NDArray[np.float32]:
        """(p,) 1 for lit points (p, 3) m, 0 in shadow."""
        lit = lookup_shadow(np.ascontiguousarray(world @ self.frame.T), self.grid, self.map,
                            SHADOW_BIAS_M)
        return np.asarray(lit, np.float32)


def _round_trip(camera: Any, ideal: FloatArray, pix: FloatArray) -> NDArray[np.bool_]:
    """(n,) True where the ideal pixels (n, 2) distort back onto ``pix`` (n, 2) within 0.05 px
    (the iterative inversion of the lens model fails in the far corners of a strong k3)."""
    k = camera.K
    norm = np.column_stack([(ideal[:, 0] - k[0, 2]) / k[0, 0], (ideal[:, 1] - k[1, 2]) / k[1, 1],
                            np.ones(len(ideal))])
    ok = np.isfinite(norm).all(axis=1)
    back = np.full_like(pix, np.inf)
    proj, _ = cv2.projectPoints(norm[ok].reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k,
                                np.asarray(camera.dist, np.float64))
    back[ok] = proj.reshape(-1, 2)
    return np.asarray(np.linalg.norm(back - pix, axis=1) < 0.05)


def _ground(size: tuple[int, int], rng: np.random.Generator) -> NDArray[np.float32]:
    """(h, w, 3) albedo of what lies beyond the bin: darker, blotchy soil."""
    w, h = size
    coarse = cv2.resize(rng.random((h // 24 + 1, w // 24 + 1)).astype(np.float32), (w, h),
                        interpolation=cv2.INTER_CUBIC)
    grain = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 1.0)
    tone = 0.55 + 0.25 * coarse + 0.2 * (grain - 0.5)
    return (np.array([0.20, 0.26, 0.30], np.float32) * tone[..., None]).astype(np.float32)
