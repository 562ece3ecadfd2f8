"""Synthetic marker images with known sub-pixel centres for the detection and tracking tests.

Blue clay discs (shaded like spheres) on a sand texture, rendered 8x supersampled and box
filtered, with read noise and JPEG: a known-truth image that does not need the field renderer.
"""

from __future__ import annotations

import cv2
import numpy as np

SAND = np.array([0.42, 0.58, 0.72])  # BGR albedo
CLAY = np.array([0.62, 0.22, 0.10])
SS = 8  # supersampling


def sand(shape: tuple[int, int], rng: np.random.Generator,
         albedo: np.ndarray = SAND) -> np.ndarray:
    """(h, w, 3) float sand radiance: grains of about 3 px with their own tone."""
    h, w = shape
    tone = cv2.resize(rng.normal(1.0, 0.12, (h // 3 + 1, w // 3 + 1)), (w, h),
                      interpolation=cv2.INTER_NEAREST)
    return albedo[None, None, :] * tone[..., None]


def spot_image(shape: tuple[int, int], centres: np.ndarray, radius: float,
               rng: np.random.Generator, gain: float = 1.0, noise_dn: float = 1.5,
               quality: int = 90, shadow_cols: int = 0, sand_coloured: tuple[int, ...] = (),
               dirt: tuple[float, float, float] | None = None,
               sand_bgr: np.ndarray = SAND, clay_bgr: np.ndarray = CLAY,
               buried: float | np.ndarray = 0.0,
               streak: tuple[float, float] = (0.0, 0.0), lit_from_up: float = 0.0) -> bytes:
    """JPEG of markers at ``centres`` (n, 2) px (pixel-centre convention) on sand.

    ``shadow_cols`` > 0 darkens the left part of the image to 35 % (a shadow);
    ``sand_coloured`` markers are drawn in the sand's colour; ``dirt`` (cx, cy, r) px puts a
    blurred brown blot of dirt on the lens; ``sand_bgr`` and ``clay_bgr`` are the albedos;
    ``buried`` is the share of each marker's height below the sand (its lower part hidden), one
    for all or one per marker; ``streak`` (du, dv) px is each marker's motion during the
    exposure (a long shutter): the disc is drawn at 16 places along it, centred on its centre,
    and the exposures averaged; ``lit_from_up`` (0..1) lights each marker from above the image:
    its top ``1 + lit_from_up`` times as bright as its middle, its bottom ``1 - lit_from_up``.
    """
    h, w = shape
    img = sand(shape, rng, sand_bgr)
    depth = np.broadcast_to(np.asarray(buried, np.float64), (len(centres),))
    du, dv = streak
    steps = np.linspace(-0.5, 0.5, 16) if du or dv else np.zeros(1)
    for k, (cx, cy) in enumerate(centres):
        colour = sand_bgr * 0.9 if k in sand_coloured else clay_bgr
        reach = radius + 0.5 * max(abs(du), abs(dv))
        x0, y0 = int(np.floor(cx - reach)) - 1, int(np.floor(cy - reach)) - 1
        n = int(np.ceil(2 * reach)) + 3
        sub = (np.arange(n * SS) + 0.5) / SS - 0.5
        xx, yy = np.meshgrid(x0 + sub, y0 + sub)
        cov, rad = np.zeros((n, n)), np.zeros((n, n))
        for t in steps:
            px, py = cx + t * du, cy + t * dv
            d2 = ((xx - px) ** 2 + (yy - py) ** 2) / radius ** 2
            inside = (d2 < 1) & (yy < py + radius * (1 - 2 * depth[k]))
            shade = np.where(inside, (0.5 + 0.5 * np.sqrt(np.clip(1 - d2, 0, 1)))
                             * (1 - lit_from_up * (yy - py) / radius), 0)
            cov += cv2.resize(inside.astype(np.float64), (n, n), interpolation=cv2.INTER_AREA)
            rad += cv2.resize(shade, (n, n), interpolation=cv2.INTER_AREA)
        cov, rad = cov / len(steps), rad / len(steps)
        ys, xs = slice(max(y0, 0), min(y0 + n, h)), slice(max(x0, 0), min(x0 + n, w))
        cy0, cx0 = ys.start - y0, xs.start - x0
        c = cov[cy0:cy0 + ys.stop - ys.start, cx0:cx0 + xs.stop - xs.start, None]
        r = rad[cy0:cy0 + ys.stop - ys.start, cx0:cx0 + xs.stop - xs.start, None]
        img[ys, xs] = img[ys, xs] * (1 - c) + colour * r
    img = img * gain
    if dirt is not None:
        blot = np.zeros((h, w))
        cv2.circle(blot, (round(dirt[0]), round(dirt[1])), round(dirt[2]), 1.0, -1)
        blot = cv2.GaussianBlur(blot, (0, 0), dirt[2] / 4)[..., None]
        img = img * (1 - blot) + np.array([0.10, 0.16, 0.22]) * blot
    if shadow_cols:
        img[:, :shadow_cols] *= 0.35
    img = 230 * img + rng.normal(0, noise_dn, img.shape)
    ok, buf = cv2.imencode('.jpg', np.clip(np.rint(img), 0, 255).astype(np.uint8),
                           [cv2.IMWRITE_JPEG_QUALITY, quality])
    assert ok
    return buf.tobytes()


def cut_disc_patch(shape: tuple[int, int], centres: np.ndarray, cuts: tuple[float, ...],
                   radius: float) -> np.ndarray:
    """(h, w) float32 chroma of discs of ``radius`` at ``centres`` (k, 2) px, each hidden below
    a chord ``cuts`` (k,) radii from its centre (-1: whole), drawn 8x supersampled on sand at
    -0.2, markers at +0.5 (the cut-disc model's image, ``tracking.cut_discs``)."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w]
    xy = np.column_stack([xx.ravel(), yy.ravel()]).astype(np.float64)
    sub = (np.arange(8) + 0.5) / 8 - 0.5
    ox, oy = np.meshgrid(sub, sub)
    pts = xy[:, None, :] + np.column_stack([ox.ravel(), oy.ravel()])[None]
    seen = np.zeros(pts.shape[:2], bool)
    for c, cut in zip(centres, cuts, strict=True):
        d = pts - c
        seen |= (np.hypot(d[..., 0], d[..., 1]) <= radius) & (-d[..., 1] >= cut * radius)
    return (-0.2 + 0.7 * seen.mean(1)).reshape(h, w).astype(np.float32)
