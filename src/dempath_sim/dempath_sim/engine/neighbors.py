# mypy: disable-error-code="no-untyped-def"
"""Cell-list half neighbour list (Verlet list with a skin); the springs follow in `history.py`.

Pairs (i, j), j > i, with |x_i - x_j| < r_i + r_j + skin are stored in CSR form (`start` (n+1,),
`nbr` (m,)). Cells have edge `cell` (about two typical radii plus the skin); particle i searches
+-s_i cells with s_i = ceil((r_i + r_max + skin) / cell), which keeps wide size distributions
(two-layer beds) cheap. The list stays valid while no particle has moved more than skin / 2
since the build (Allen & Tildesley, Computer Simulation of Liquids, 2nd ed., 5.3).
Build: counting sort of particles by cell (serial), then one parallel pass over particles that
counts the pairs of each particle and writes them into a (n, cap) scratch table, then a parallel
copy into CSR form. `cap` comes from the previous list (its longest row plus a margin); without
it, or when a row overflows, a second pass writes the CSR list directly (counts are exact).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

MAX_CELLS_PER_PARTICLE = 8  # grid is coarsened beyond this many cells per particle


def choose_cell_size(radii: NDArray[np.float64], skin: float,
                     extent: NDArray[np.float64]) -> float:
    """Cell edge [m]: twice the median radius plus the skin, coarsened to bound the cell count."""
    cell = 2.0 * float(np.median(radii)) + skin
    n_max = MAX_CELLS_PER_PARTICLE * len(radii) + 1000
    while np.prod(np.floor(extent / cell) + 1.0) > n_max:
        cell *= 1.25
    return cell


@njit(cache=True)
def sort_into_cells(pos, lo, cell, dims):  # pragma: no cover - compiled
    """Counting sort by cell: returns (cell_of (n,), cell_start (n_cells + 1,), order (n,))."""
    n = pos.shape[0]
    n_cells = dims[0] * dims[1] * dims[2]
    cell_of = np.empty(n, np.int64)
    counts = np.zeros(n_cells + 1, np.int64)
    for i in range(n):
        cx = min(max(int((pos[i, 0] - lo[0]) / cell), 0), dims[0] - 1)
        cy = min(max(int((pos[i, 1] - lo[1]) / cell), 0), dims[1] - 1)
        cz = min(max(int((pos[i, 2] - lo[2]) / cell), 0), dims[2] - 1)
        cell_of[i] = (cx * dims[1] + cy) * dims[2] + cz
        counts[cell_of[i] + 1] += 1
    for c in range(n_cells):
        counts[c + 1] += counts[c]
    fill = counts[:-1].copy()
    order = np.empty(n, np.int64)
    for i in range(n):
        order[fill[cell_of[i]]] = i
        fill[cell_of[i]] += 1
    return cell_of, counts, order


@njit(parallel=True, cache=True)
def scan_pairs(spos, srad, r_max, skin, lo, cell, dims, cell_start, order, start,
               nbr, table, fill, forward):  # pragma: no cover - compiled
    """Count the pairs of each i into start[i+1] (fill=False; the first table.shape[1] pairs of
    i also go to table[i] when table has rows) or write them into nbr from start[i] (fill=True).

    spos (n, 3) and srad (n,) are the positions and radii in cell order (spos[q] is particle
    order[q]); particles are visited in cell order so that neighbouring visits share cells.
    forward: the particles already are in cell order (order is the identity), so j > i lie in
    later cells and only the forward half of the stencil is scanned (same list, same order).
    """
    n = spos.shape[0]
    for qi in prange(n):
        i = order[qi]
        s = math.ceil((srad[qi] + r_max + skin) / cell)
        cx = min(max(int((spos[qi, 0] - lo[0]) / cell), 0), dims[0] - 1)
        cy = min(max(int((spos[qi, 1] - lo[1]) / cell), 0), dims[1] - 1)
        cz = min(max(int((spos[qi, 2] - lo[2]) / cell), 0), dims[2] - 1)
        count = 0
        out = start[i] if fill else 0
        cap = table.shape[1] if table.shape[0] > 0 else 0
        for ax in range(cx if forward else max(cx - s, 0), min(cx + s, dims[0] - 1) + 1):
            for ay in range(max(cy - s, 0), min(cy + s, dims[1] - 1) + 1):
                if forward and ax == cx and ay < cy:
                    continue
                c0 = (ax * dims[1] + ay) * dims[2]
                q_lo = cell_start[c0 + max(cz - s, 0)]
                q_hi = cell_start[c0 + min(cz + s, dims[2] - 1) + 1]
                if forward and ax == cx and ay == cy:
                    q_lo = qi + 1
                for q in range(q_lo, q_hi):  # the z-run of cells is contiguous in cell order
                    j = order[q]
                    if j <= i:
                        continue
                    dx = spos[qi, 0] - spos[q, 0]
                    dy = spos[qi, 1] - spos[q, 1]
                    dz = spos[qi, 2] - spos[q, 2]
                    cut = srad[qi] + srad[q] + skin
                    if dx * dx + dy * dy + dz * dz < cut * cut:
                        if fill:
                            nbr[out + count] = j
                        elif count < cap:
                            table[i, count] = j
                        count += 1
        if not fill:
            start[i + 1] = count


@njit(parallel=True, cache=True)
def copy_table(table, start, nbr):  # pragma: no cover - compiled
    """nbr[start[i]:start[i+1]] = table[i, :start[i+1] - start[i]] (rows fit the table)."""
    for i in prange(table.shape[0]):
        for k in range(start[i + 1] - start[i]):
            nbr[start[i] + k] = table[i, k]


@njit(cache=True)
def bounds(pos):  # pragma: no cover - compiled
    """(lo (3,), hi (3,)) corners of the points pos (n, 3), n > 0 (numpy's axis=0 min/max of an
    (n, 3) array is ~10x slower)."""
    lo = pos[0].copy()
    hi = pos[0].copy()
    for i in range(pos.shape[0]):
        for d in range(3):
            lo[d] = min(lo[d], pos[i, d])
            hi[d] = max(hi[d], pos[i, d])
    return lo, hi


def permute_in_place(arr: NDArray[np.generic], order: NDArray[np.int64],
                     scratch: NDArray[np.uint8] | None = None) -> None:
    """Rows of the C-contiguous array arr (n, ...) permuted in place: row k = old row order[k].

    scratch: optional uint8 buffer of at least arr.nbytes reused as the temporary (a fresh one
    costs page faults on every call).
    """
    if not arr.flags.c_contiguous:
        msg = 'permute_in_place needs a C-contiguous array'
        raise ValueError(msg)
    rows = arr.reshape(len(arr), -1)  # a view of the contiguous array
    if scratch is None or scratch.nbytes < arr.nbytes:
        tmp = np.empty_like(rows)
    else:
        tmp = scratch[:arr.nbytes].view(arr.dtype).reshape(rows.shape)
    np.take(rows, order, axis=0, out=tmp)
    rows[...] = tmp


def cell_grid(pos: NDArray[np.float64], rad: NDArray[np.float64],
              skin: float) -> tuple[NDArray[np.float64], float, NDArray[np.int64]]:
    """Cell grid of a neighbour-list build: (lower corner (3,) [m], cell edge [m], dims (3,))."""
    p_lo, p_hi = bounds(pos)
    lo = p_lo - 1e-9
    extent = p_hi - lo + 1e-9
    cell = choose_cell_size(rad, skin, extent)
    return lo, cell, (np.floor(extent / cell) + 1).astype(np.int64)


def cell_order(pos: NDArray[np.float64], rad: NDArray[np.float64],
               skin: float) -> NDArray[np.int64]:
    """(n,) permutation that puts the particles in the cell order of the list build.

    Particles that are close in space then lie close in memory, so the force loops touch fewer
    cache lines; within a cell the current order is kept (stable, deterministic).
    """
    if len(rad) == 0:
        return np.zeros(0, np.int64)
    lo, cell, dims = cell_grid(pos, rad, skin)
    order: NDArray[np.int64] = sort_into_cells(pos, lo, cell, dims)[2]
    return order


class CellGrid(NamedTuple):
    """The cells of a list build: particle i of a state in cell order lies in cell c for
    cell_start[c] <= i < cell_start[c + 1] (``in_order``; otherwise the ranges index the
    build's sort order, not the particles)."""

    lo: NDArray[np.float64]  # (3,) lower corner [m]
    cell: float  # edge [m]
    dims: NDArray[np.int64]  # (3,) cells per axis
    cell_start: NDArray[np.int64]  # (n_cells + 1,) first sorted particle of each cell
    in_order: bool  # the particles were in cell order at the build


def build_neighbor_list(pos: NDArray[np.float64], rad: NDArray[np.float64],
                        skin: float, cap: int = 0) -> tuple[NDArray[np.int64], NDArray[np.int32]]:
    """Half neighbour list of spheres within r_i + r_j + skin.

    Args:
        pos: (n, 3) centres [m].
        rad: (n,) radii [m].
        skin: Absolute skin distance [m].
        cap: Expected longest row; > 0 builds in one pass through a (n, cap) int32 scratch
            table (a longer row costs a second pass, never a wrong list); 0 always scans twice.

    Returns:
        (start (n+1,) int64, nbr (m,) int32): the neighbours j > i of i are
        nbr[start[i]:start[i+1]].
    """
    start, nbr, _ = build_neighbor_cells(pos, rad, skin, cap)
    return start, nbr


def build_neighbor_cells(pos: NDArray[np.float64], rad: NDArray[np.float64], skin: float,
                         cap: int = 0) -> tuple[NDArray[np.int64], NDArray[np.int32],
                                                CellGrid | None]:
    """`build_neighbor_list` and the cells it sorted the particles into (None for n = 0)."""
    n = len(rad)
    start = np.zeros(n + 1, np.int64)
    if n == 0:
        return start, np.zeros(0, np.int32), None
    lo, cell, dims = cell_grid(pos, rad, skin)
    _, cell_start, order = sort_into_cells(pos, lo, cell, dims)
    forward = bool(np.array_equal(order, np.arange(n)))  # the engine sorted the particles
    spos = pos if forward else pos[order]
    srad = rad if forward else rad[order]
    r_max = float(rad.max())
    dummy = np.zeros(0, np.int32)
    table = np.empty((n if cap > 0 else 0, max(cap, 1)), np.int32)
    scan_pairs(spos, srad, r_max, skin, lo, cell, dims, cell_start, order, start, dummy, table,
               False, forward)
    fits = cap > 0 and int(start.max()) <= cap
    np.cumsum(start, out=start)
    nbr = np.empty(int(start[-1]), np.int32)
    if fits:
        copy_table(table, start, nbr)
    else:
        scan_pairs(spos, srad, r_max, skin, lo, cell, dims, cell_start, order, start, nbr,
                   table, True, forward)
    return start, nbr, CellGrid(lo, cell, dims, cell_start, forward)


def overlapping_pairs(positions: NDArray[np.float64], radii: NDArray[np.float64],
                      start: NDArray[np.int64], nbr: NDArray[np.int32]) -> int:
    """Pairs of the neighbour list (CSR ``start`` (n + 1,), ``nbr``) whose spheres overlap now."""
    if nbr.size == 0:
        return 0
    i = np.repeat(np.arange(len(start) - 1), np.diff(start))
    d = np.linalg.norm(positions[i] - positions[nbr], axis=1)
    return int(np.count_nonzero(d < radii[i] + radii[nbr]))
