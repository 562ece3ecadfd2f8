# mypy: disable-error-code="no-untyped-def"
"""A triangle mesh as a solid: is it closed, which points lie inside, how far is its surface.

The tool's carve into the bed (``runs.bed.placement``) removes the particles that overlap the
tool's own volume, so it needs an inside test and the distance to the surface. Inside is decided by
the generalised winding number (Jacobson, Kavan & Sorkine-Hornung, "Robust inside-outside
segmentation using generalized winding numbers", ACM TOG 32(4), 2013): the sum over the triangles
of the solid angle each subtends at the point (Van Oosterom & Strackee, IEEE TBME 30(2), 1983),
over 4 pi. It is 1 inside a closed outward-oriented shell, 0 outside, and, unlike ray parity, it
stays right for meshes built from overlapping closed shells (dempath's chisel: share and shank) and
for inward-oriented shells (|w| is used). It is only meaningful for a closed mesh: every edge
shared by triangles running along it in both directions (`open_edges` finds those that are not).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from dempath_sim.engine.mesh import closest_point_triangle

F64 = NDArray[np.float64]
WELD_FRACTION = 1e-7  # vertices closer than this times the mesh size are one vertex


def open_edges(triangles: F64) -> int:
    """How many edges of the mesh are not closed (0 for a closed mesh).

    Vertices are welded at ``WELD_FRACTION`` of the mesh size (STL repeats them per triangle).
    An edge is closed when it is used as often in one direction as in the other (two
    triangles of one consistently oriented shell; overlapping shells each close their own).
    """
    flat = triangles.reshape(-1, 3)
    size = float(np.ptp(flat, axis=0).max()) or 1.0
    keys = np.round((flat - flat.min(axis=0)) / (size * WELD_FRACTION)).astype(np.int64)
    _, vertex = np.unique(keys, axis=0, return_inverse=True)
    tri = vertex.reshape(-1, 3)
    n_vert = int(vertex.max()) + 1
    start, end = tri.reshape(-1), tri[:, [1, 2, 0]].reshape(-1)
    codes, counts = np.unique(start * n_vert + end, return_counts=True)
    reverse = (codes % n_vert) * n_vert + codes // n_vert
    at = np.searchsorted(codes, reverse).clip(0, len(codes) - 1)
    back = np.where(codes[at] == reverse, counts[at], 0)
    return int(np.count_nonzero(back != counts))


@njit(cache=True)
def winding_numbers(points, triangles):  # pragma: no cover - compiled
    """Generalised winding number (m,) of each point (m, 3) with respect to the mesh (n, 3, 3)."""
    out = np.zeros(points.shape[0])
    for k in range(points.shape[0]):
        total = 0.0
        for t in range(triangles.shape[0]):
            a = triangles[t, 0] - points[k]
            b = triangles[t, 1] - points[k]
            c = triangles[t, 2] - points[k]
            la, lb, lc = np.sqrt(a @ a), np.sqrt(b @ b), np.sqrt(c @ c)
            det = (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                   + a[2] * (b[0] * c[1] - b[1] * c[0]))
            den = la * lb * lc + (a @ b) * lc + (b @ c) * la + (c @ a) * lb
            total += 2.0 * np.arctan2(det, den)
        out[k] = total / (4.0 * np.pi)
    return out


@njit(cache=True)
def surface_distances(points, triangles):  # pragma: no cover - compiled
    """Distance (m,) [m] of each point (m, 3) to the nearest triangle of the mesh (n, 3, 3)."""
    out = np.full(points.shape[0], np.inf)
    for k in range(points.shape[0]):
        for t in range(triangles.shape[0]):
            qx, qy, qz = closest_point_triangle(points[k, 0], points[k, 1], points[k, 2],
                                                triangles[t])
            d2 = (points[k, 0] - qx) ** 2 + (points[k, 1] - qy) ** 2 + (points[k, 2] - qz) ** 2
            out[k] = min(out[k], np.sqrt(d2))
    return out


def overlapping_spheres(triangles: F64, centres: F64, radii: F64) -> NDArray[np.bool_]:
    """(m,) bool: spheres whose centre lies inside the closed mesh or that cut its surface.

    Only the spheres within the mesh's bounding box grown by their radius are tested.
    """
    flat = triangles.reshape(-1, 3)
    lo, hi = flat.min(axis=0), flat.max(axis=0)
    r = radii[:, None]
    near = np.flatnonzero(np.all((centres > lo - r) & (centres < hi + r), axis=1))
    hit = np.zeros(len(centres), bool)
    if len(near):
        pts = np.ascontiguousarray(centres[near])
        tris = np.ascontiguousarray(triangles, dtype=np.float64)
        inside = np.abs(winding_numbers(pts, tris)) > 0.5
        cuts = surface_distances(pts, tris) < radii[near]
        hit[near] = inside | cuts
    return hit


__all__ = ['open_edges', 'overlapping_spheres', 'surface_distances', 'winding_numbers']
