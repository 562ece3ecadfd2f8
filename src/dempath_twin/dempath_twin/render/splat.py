"""Z-buffered splatting of spheres and triangles into an ideal pinhole image, and shadows.

The field recordings are rendered from the simulated bed itself: every sphere is splatted into
an ideal (undistorted) pinhole image with a depth test, so grains in front hide grains and
markers behind them (painter's algorithm by z-buffer, not a visibility flag); the tool's
triangles go through the same depth test. Each pixel keeps the depth, the index of what it
shows and the surface normal, from which ``camera_frame`` shades it. Shadows come from a
second depth buffer seen from the light (an orthographic shadow map, Williams 1978).

Geometry: camera frame x right, y down, z forward (OpenCV); an ideal pixel (i, j) of a buffer
with origin ``(ox, oy)`` sits at ideal image coordinates ``(ox + i / ss, oy + j / ss)`` with
pixel centres on integers (OpenCV's convention). A sphere of radius r at depth z covers the
ellipse of radii ``(fx r / z, fy r / z)`` around its projected centre; the ellipse is the exact
outline to first order in r / z (its centre is off by less than 0.02 px for 8 mm at 0.6 m).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
NO_HIT = -1  # index buffer value of a pixel that shows nothing
NEAR_M = 0.05  # nearest depth rendered [m]


@numba.njit(cache=True)  # type: ignore[misc]  # numba ships no types
def splat_spheres(centres: FloatArray, radii: FloatArray, intr: FloatArray,
                  zbuf: NDArray[np.float32], ibuf: NDArray[np.int32],
                  nbuf: NDArray[np.float32]) -> None:  # pragma: no cover - compiled
    """Depth-test every sphere into the buffers.

    Args:
        centres: (n, 3) sphere centres in the camera frame [m] (NaN rows are skipped).
        radii: (n,) radii [m].
        intr: (6,) fx, fy, cx, cy [px], ox, oy [ideal px] and nothing else; ss is zbuf's scale
            folded into fx, fy, cx, cy, ox, oy by the caller.
        zbuf: (h, w) depth [m], updated in place.
        ibuf: (h, w) index of the sphere shown, updated in place.
        nbuf: (h, w, 3) unit surface normal in the camera frame, updated in place.
    """
    fx, fy, cx, cy, ox, oy = intr[0], intr[1], intr[2], intr[3], intr[4], intr[5]
    h, w = zbuf.shape
    for k in range(centres.shape[0]):
        z = centres[k, 2]
        if not (z > NEAR_M):
            continue
        r = radii[k]
        u = fx * centres[k, 0] / z + cx - ox
        v = fy * centres[k, 1] / z + cy - oy
        ru, rv = fx * r / z, fy * r / z
        i0, i1 = max(int(np.floor(u - ru)), 0), min(int(np.ceil(u + ru)), w - 1)
        j0, j1 = max(int(np.floor(v - rv)), 0), min(int(np.ceil(v + rv)), h - 1)
        for j in range(j0, j1 + 1):
            dy = (j - v) / rv
            for i in range(i0, i1 + 1):
                dx = (i - u) / ru
                d2 = dx * dx + dy * dy
                if d2 >= 1.0:
                    continue
                dz = np.sqrt(1.0 - d2)
                depth = z - r * dz
                if depth < zbuf[j, i]:
                    zbuf[j, i] = depth
                    ibuf[j, i] = k
                    nbuf[j, i, 0] = dx
                    nbuf[j, i, 1] = dy
                    nbuf[j, i, 2] = -dz


@numba.njit(cache=True)  # type: ignore[misc]  # numba ships no types
def triangle_pixels(pu: FloatArray, pv: FloatArray, w: int, h: int,
                    ) -> tuple[NDArray[np.int64], FloatArray]:  # pragma: no cover - compiled
    """Pixels (p, 2) as (i, j) whose centres lie in the triangle of corners (pu, pv) (3,) px,
    inside a w x h buffer, and their barycentric weights (p, 3)."""
    den = (pv[1] - pv[2]) * (pu[0] - pu[2]) + (pu[2] - pu[1]) * (pv[0] - pv[2])
    i0, i1 = max(int(np.floor(pu.min())), 0), min(int(np.ceil(pu.max())), w - 1)
    j0, j1 = max(int(np.floor(pv.min())), 0), min(int(np.ceil(pv.max())), h - 1)
    n = max(i1 - i0 + 1, 0) * max(j1 - j0 + 1, 0) if abs(den) >= 1e-12 else 0
    pix = np.empty((n, 2), np.int64)
    lam = np.empty((n, 3))
    q = 0
    for j in range(j0, j1 + 1 if n else j0):
        for i in range(i0, i1 + 1):
            l0 = ((pv[1] - pv[2]) * (i - pu[2]) + (pu[2] - pu[1]) * (j - pv[2])) / den
            l1 = ((pv[2] - pv[0]) * (i - pu[2]) + (pu[0] - pu[2]) * (j - pv[2])) / den
            l2 = 1.0 - l0 - l1
            if l0 >= 0 and l1 >= 0 and l2 >= 0:
                pix[q, 0], pix[q, 1] = i, j
                lam[q, 0], lam[q, 1], lam[q, 2] = l0, l1, l2
                q += 1
    return pix[:q], lam[:q]


@numba.njit(cache=True)  # type: ignore[misc]  # numba ships no types
def raster_triangles(tris: FloatArray, intr: FloatArray, index: int,
                     zbuf: NDArray[np.float32], ibuf: NDArray[np.int32],
                     nbuf: NDArray[np.float32]) -> None:  # pragma: no cover - compiled
    """Depth-test triangles (k, 3, 3) in the camera frame [m]; they show as ``index``.

    Depth is interpolated in screen space (perspective-correct 1/z); the normal is the face's,
    turned towards the camera.
    """
    fx, fy, cx, cy, ox, oy = intr[0], intr[1], intr[2], intr[3], intr[4], intr[5]
    h, w = zbuf.shape
    for k in range(tris.shape[0]):
        a, b, c = tris[k, 0], tris[k, 1], tris[k, 2]
        if a[2] <= NEAR_M or b[2] <= NEAR_M or c[2] <= NEAR_M:
            continue
        n = np.cross(b - a, c - a)
        norm = np.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2)
        if norm == 0.0:
            continue
        n = n / norm
        if n[0] * a[0] + n[1] * a[1] + n[2] * a[2] > 0:
            n = -n
        pu = np.array([fx * p[0] / p[2] + cx - ox for p in (a, b, c)])
        pv = np.array([fy * p[1] / p[2] + cy - oy for p in (a, b, c)])
        iz = np.array([1.0 / a[2], 1.0 / b[2], 1.0 / c[2]])
        pix, lam = triangle_pixels(pu, pv, w, h)
        for q in range(pix.shape[0]):
            i, j = pix[q, 0], pix[q, 1]
            depth = 1.0 / (lam[q, 0] * iz[0] + lam[q, 1] * iz[1] + lam[q, 2] * iz[2])
            if depth < zbuf[j, i]:
                zbuf[j, i] = depth
                ibuf[j, i] = index
                nbuf[j, i, 0] = n[0]
                nbuf[j, i, 1] = n[1]
                nbuf[j, i, 2] = n[2]


@numba.njit(cache=True)  # type: ignore[misc]  # numba ships no types
def splat_shadow(points: FloatArray, radii: FloatArray, grid: FloatArray,
                 smap: NDArray[np.float32]) -> None:  # pragma: no cover - compiled
    """Orthographic shadow map: nearest depth along the light of every sphere.

    Args:
        points: (n, 3) centres in light coordinates (a, b, depth along the light) [m].
        radii: (n,) radii [m].
        grid: (3,) a0, b0 [m] of cell (0, 0) and the cell size [m].
        smap: (h, w) depth buffer, updated in place.
    """
    a0, b0, cell = grid[0], grid[1], grid[2]
    h, w = smap.shape
    for k in range(points.shape[0]):
        if not np.isfinite(points[k, 2]):
            continue
        r = radii[k]
        ua, ub = (points[k, 0] - a0) / cell, (points[k, 1] - b0) / cell
        rc = r / cell
        i0, i1 = max(int(np.floor(ua - rc)), 0), min(int(np.ceil(ua + rc)), w - 1)
        j0, j1 = max(int(np.floor(ub - rc)), 0), min(int(np.ceil(ub + rc)), h - 1)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                d2 = ((i - ua) ** 2 + (j - ub) ** 2) / (rc * rc)
                if d2 < 1.0:
                    depth = points[k, 2] - r * np.sqrt(1.0 - d2)
                    if depth < smap[j, i]:
                        smap[j, i] = depth


@numba.njit(cache=True)  # type: ignore[misc]  # numba ships no types
def lookup_shadow(points: FloatArray, grid: FloatArray, smap: NDArray[np.float32],
                  bias: float) -> NDArray[np.float32]:  # pragma: no cover - compiled
    """(n,) 1 where a point (n, 3) in light coordinates is lit, 0 where something is nearer."""
    a0, b0, cell = grid[0], grid[1], grid[2]
    h, w = smap.shape
    out = np.ones(points.shape[0], np.float32)
    for k in range(points.shape[0]):
        i = int(np.floor((points[k, 0] - a0) / cell + 0.5))
        j = int(np.floor((points[k, 1] - b0) / cell + 0.5))
        if 0 <= i < w and 0 <= j < h and points[k, 2] > smap[j, i] + bias:
            out[k] = 0.0
    return out


def light_frame(direction: FloatArray) -> FloatArray:
    """(3, 3) rows a, b, d: two axes across the light and ``d`` along it (towards the ground).

    ``direction`` (3,) points from the scene towards the light (world frame).
    """
    d = -np.asarray(direction, np.float64) / np.linalg.norm(direction)
    helper = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    a = np.cross(helper, d)
    a /= np.linalg.norm(a)
    return np.vstack([a, np.cross(d, a), d])


@numba.njit(cache=True)  # type: ignore[misc]  # numba ships no types
def raster_shadow_triangles(tris: FloatArray, grid: FloatArray,
                            smap: NDArray[np.float32]) -> None:  # pragma: no cover - compiled
    """Orthographic shadow map of triangles (k, 3, 3) in light coordinates [m]."""
    a0, b0, cell = grid[0], grid[1], grid[2]
    h, w = smap.shape
    for k in range(tris.shape[0]):
        pu = (tris[k, :, 0] - a0) / cell
        pv = (tris[k, :, 1] - b0) / cell
        pz = tris[k, :, 2]
        pix, lam = triangle_pixels(pu, pv, w, h)
        for q in range(pix.shape[0]):
            i, j = pix[q, 0], pix[q, 1]
            depth = lam[q, 0] * pz[0] + lam[q, 1] * pz[1] + lam[q, 2] * pz[2]
            if depth < smap[j, i]:
                smap[j, i] = depth
