# mypy: disable-error-code="no-untyped-def"
"""Triangle-mesh geometry of the tool: the mesh record, a triangle grid and closest points.

The mesh is stored in its own (tool) frame; a `ToolPose` places that frame in the world. For
the contact search the triangles are binned in a uniform grid of the tool frame, each triangle in
every cell its bounding box, grown by the largest particle radius, touches; a particle then only
tests the triangles of its own cell. The closest point of a triangle to a sphere centre follows
Ericson, Real-Time Collision Detection (2005), 5.1.5.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from dempath_sim.engine.stl import read_stl
from dempath_sim.errors import GeometryError

MAX_GRID_CELLS = 2_000_000  # the triangle grid is coarsened beyond this
GRID_CHUNK = 50_000  # triangles binned per compiled call (progress and Ctrl-C between calls)
# Above this many triangles the run slows noticeably (contact search, carve); say so.
SLOW_TRIANGLES = 200_000
GridProgress = Callable[[int, int], None]  # (triangles binned, total)
logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class TriangleMesh:
    """A rigid triangle mesh in its own frame.

    Attributes:
        triangles: (n_tri, 3, 3) vertices [m] in the tool frame.
        material: Material index into SimParams.materials.
        name: Label for messages (e.g. the STL path).
    """

    triangles: NDArray[np.float64]
    material: int = 0
    name: str = 'mesh'

    def __post_init__(self) -> None:
        """Check the shape and drop degenerate (zero-area) triangles."""
        tris = np.ascontiguousarray(self.triangles, dtype=np.float64)
        if tris.ndim != 3 or tris.shape[1:] != (3, 3) or not np.isfinite(tris).all():
            msg = f'TriangleMesh {self.name!r}: triangles must be finite (n, 3, 3), ' \
                  f'got shape {tris.shape}'
            raise GeometryError(msg)
        area = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
        tris = tris[area > 1e-12 * max(float(area.max(initial=0.0)), 1e-30)]
        if len(tris) == 0:
            msg = f'TriangleMesh {self.name!r}: no triangle with a non-zero area'
            raise GeometryError(msg)
        object.__setattr__(self, 'triangles', tris)

    @classmethod
    def from_stl(cls, path: str | Path, material: int = 0, scale: float = 1.0,
                 offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> TriangleMesh:
        """Load an STL file; vertices become scale * v + offset [m].

        Raises:
            GeometryError: The file is missing, empty, truncated or malformed.
        """
        tris = read_stl(path) * scale + np.asarray(offset, dtype=np.float64)
        return cls(tris, material, str(path))

    @property
    def bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(lo (3,), hi (3,)) bounding box in the tool frame [m]."""
        flat = self.triangles.reshape(-1, 3)
        return flat.min(axis=0), flat.max(axis=0)


@dataclass(frozen=True)
class TriangleGrid:
    """Triangles binned in a uniform grid of the tool frame (CSR: cell -> triangle indices)."""

    lo: NDArray[np.float64]
    cell: float
    dims: NDArray[np.int64]
    cell_start: NDArray[np.int64]
    cell_tris: NDArray[np.int32]

    @staticmethod
    def kernel_args(grid: TriangleGrid | None) -> tuple[Any, ...]:
        """(lo, cell, dims, cell_start, cell_tris) for the boundary kernel; an empty grid for
        None (no tool)."""
        if grid is None:
            return (np.zeros(3), 1.0, np.ones(3, np.int64), np.zeros(2, np.int64),
                    np.zeros(0, np.int32))
        return grid.lo, grid.cell, grid.dims, grid.cell_start, grid.cell_tris


def build_triangle_grid(mesh: TriangleMesh, margin: float,
                        progress: GridProgress | None = None) -> TriangleGrid:
    """Bin the triangles into cells of edge about 2 margin, each box grown by margin [m].

    The binning runs compiled, in chunks of ``GRID_CHUNK`` triangles, so that a mesh of millions
    of triangles takes seconds, ``progress`` (triangles done, total) is called between chunks
    and Ctrl-C (KeyboardInterrupt) stops it between chunks. Above ``SLOW_TRIANGLES`` a warning
    says that every step of the run will be slower.
    """
    tris = mesh.triangles
    if len(tris) > SLOW_TRIANGLES:
        logger.warning('tool mesh %s has %d triangles (more than %d): the contact search and '
                       'the carve slow down with it; a coarser mesh of the same shape is as '
                       'accurate at the particle scale', mesh.name, len(tris), SLOW_TRIANGLES)
    tlo = tris.min(axis=1) - margin
    thi = tris.max(axis=1) + margin
    lo = tlo.min(axis=0)
    extent = thi.max(axis=0) - lo
    cell = max(2.0 * margin, 1e-6)
    while np.prod(np.floor(extent / cell) + 1) > MAX_GRID_CELLS:
        cell *= 1.25
    dims = (np.floor(extent / cell) + 1).astype(np.int64)
    c_lo = np.clip(np.floor((tlo - lo) / cell).astype(np.int64), 0, dims - 1)
    c_hi = np.clip(np.floor((thi - lo) / cell).astype(np.int64), 0, dims - 1)
    reach = margin + 0.5 * math.sqrt(3.0) * cell  # a cell centre farther away cannot matter
    cells: list[NDArray[np.int64]] = []
    owners: list[NDArray[np.int32]] = []
    for first in range(0, len(tris), GRID_CHUNK):
        chunk = slice(first, min(first + GRID_CHUNK, len(tris)))
        ids, tri_ids = _bin_triangles(tris[chunk], c_lo[chunk], c_hi[chunk], lo, cell, dims,
                                      reach, first)
        cells.append(ids)
        owners.append(tri_ids)
        if progress is not None:
            progress(chunk.stop, len(tris))
    cell_ids = np.concatenate(cells)
    tri_ids = np.concatenate(owners)
    order = np.argsort(cell_ids, kind='stable')
    n_cells = int(np.prod(dims))
    start = np.zeros(n_cells + 1, np.int64)
    np.add.at(start, cell_ids + 1, 1)
    np.cumsum(start, out=start)
    return TriangleGrid(lo, float(cell), dims, start, tri_ids[order].astype(np.int32))


@njit(cache=True)
def _near_cells(tri, c_lo, c_hi, lo, cell, dims, reach, out):  # pragma: no cover - compiled
    """Write the ids of the cells of box c_lo..c_hi whose centre lies within reach of the
    triangle into out (when given, else only count); return how many there are."""
    n = 0
    for gx in range(c_lo[0], c_hi[0] + 1):
        for gy in range(c_lo[1], c_hi[1] + 1):
            for gz in range(c_lo[2], c_hi[2] + 1):
                cx = lo[0] + (gx + 0.5) * cell
                cy = lo[1] + (gy + 0.5) * cell
                cz = lo[2] + (gz + 0.5) * cell
                qx, qy, qz = closest_point_triangle(cx, cy, cz, tri)
                if (cx - qx) ** 2 + (cy - qy) ** 2 + (cz - qz) ** 2 <= reach * reach:
                    if out.shape[0] > 0:
                        out[n] = (gx * dims[1] + gy) * dims[2] + gz
                    n += 1
    return n


@njit(cache=True)
def _bin_triangles(tris, c_lo, c_hi, lo, cell, dims, reach, first):  # pragma: no cover
    """(cell ids, triangle ids) of every (cell, triangle) pair within reach, triangle order;
    two passes (count, then fill) so that nothing grows in a Python list."""
    none = np.zeros(0, np.int64)
    counts = np.zeros(tris.shape[0], np.int64)
    for t in range(tris.shape[0]):
        counts[t] = _near_cells(tris[t], c_lo[t], c_hi[t], lo, cell, dims, reach, none)
    offsets = np.zeros(tris.shape[0] + 1, np.int64)
    offsets[1:] = np.cumsum(counts)
    ids = np.empty(offsets[-1], np.int64)
    owners = np.empty(offsets[-1], np.int32)
    for t in range(tris.shape[0]):
        _near_cells(tris[t], c_lo[t], c_hi[t], lo, cell, dims, reach,
                    ids[offsets[t]:offsets[t + 1]])
        owners[offsets[t]:offsets[t + 1]] = first + t
    return ids, owners


# LIGGGHTS 3.8 takes two faces as coplanar when |n_a . n_b| >= 1 - 1e-5 (its mesh `curvature`
# default, surface_mesh.h EPSILON_CURVATURE), i.e. within 0.26 deg.
COPLANAR_DOT = 1.0 - 1e-5


@njit(cache=True)
def _unit_normal(tri):  # pragma: no cover - compiled
    ax, ay, az = tri[1, 0] - tri[0, 0], tri[1, 1] - tri[0, 1], tri[1, 2] - tri[0, 2]
    bx, by, bz = tri[2, 0] - tri[0, 0], tri[2, 1] - tri[0, 1], tri[2, 2] - tri[0, 2]
    nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    norm = (nx * nx + ny * ny + nz * nz) ** 0.5
    return nx / norm, ny / norm, nz / norm


@njit(cache=True)
def coplanar_neighbours(tris, a, b):  # pragma: no cover - compiled
    """Whether triangles a and b share a vertex and lie in one plane (LIGGGHTS 3.8's
    ``areCoplanarNodeNeighs``: the faces between which it carries a contact's history)."""
    shared = False
    for u in range(3):
        for v in range(3):
            if (tris[a, u, 0] == tris[b, v, 0] and tris[a, u, 1] == tris[b, v, 1]
                    and tris[a, u, 2] == tris[b, v, 2]):
                shared = True
    if not shared:
        return False
    ax, ay, az = _unit_normal(tris[a])
    bx, by, bz = _unit_normal(tris[b])
    return abs(ax * bx + ay * by + az * bz) >= COPLANAR_DOT


@njit(fastmath=True, cache=True)
def closest_point_triangle(px, py, pz, tri):  # pragma: no cover - compiled
    """Closest point of triangle tri (3, 3) to p (Ericson 2005, 5.1.5).

    Returns:
        (qx, qy, qz): the closest point [m].
    """
    ax, ay, az = tri[0, 0], tri[0, 1], tri[0, 2]
    abx, aby, abz = tri[1, 0] - ax, tri[1, 1] - ay, tri[1, 2] - az
    acx, acy, acz = tri[2, 0] - ax, tri[2, 1] - ay, tri[2, 2] - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return ax, ay, az
    bpx, bpy, bpz = px - tri[1, 0], py - tri[1, 1], pz - tri[1, 2]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return tri[1, 0], tri[1, 1], tri[1, 2]
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return ax + v * abx, ay + v * aby, az + v * abz
    cpx, cpy, cpz = px - tri[2, 0], py - tri[2, 1], pz - tri[2, 2]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return tri[2, 0], tri[2, 1], tri[2, 2]
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return ax + w * acx, ay + w * acy, az + w * acz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        bx, by, bz = tri[1, 0], tri[1, 1], tri[1, 2]
        return (bx + w * (tri[2, 0] - bx), by + w * (tri[2, 1] - by), bz + w * (tri[2, 2] - bz))
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return (ax + abx * v + acx * w, ay + aby * v + acy * w, az + abz * v + acz * w)


def closest_point_triangle_numpy(p: NDArray[np.float64],
                                 tri: NDArray[np.float64]) -> NDArray[np.float64]:
    """Slow reference: closest point by projecting on the plane or clamping to the 3 edges."""
    a, b, c = tri
    nrm = np.cross(b - a, c - a)
    nrm = nrm / np.linalg.norm(nrm)
    q = p - np.dot(p - a, nrm) * nrm
    bary = np.linalg.solve(np.stack([b - a, c - a, nrm], axis=1), q - a)
    if bary[0] >= 0 and bary[1] >= 0 and bary[0] + bary[1] <= 1:
        return np.asarray(q, dtype=np.float64)
    best: NDArray[np.float64] = a
    for u, v in ((a, b), (b, c), (c, a)):
        t = float(np.clip(np.dot(p - u, v - u) / np.dot(v - u, v - u), 0.0, 1.0))
        cand = u + t * (v - u)
        if np.linalg.norm(p - cand) < np.linalg.norm(p - best):
            best = cand
    return np.asarray(best, dtype=np.float64)


def mesh_margin(radii: NDArray[np.float64]) -> float:
    """Grid margin for particles of these radii: the largest radius with 1% slack [m]."""
    return 1.01 * float(np.max(radii)) if len(radii) else 0.0


__all__ = ['TriangleGrid', 'TriangleMesh', 'build_triangle_grid', 'closest_point_triangle',
           'closest_point_triangle_numpy', 'mesh_margin']
