# mypy: disable-error-code="no-untyped-def"
"""When the neighbour list must be built again: by the grains that moved relative to each other.

The list holds every pair within r_i + r_j + skin at its build. A pair not in it can touch only
once its grains have moved by at least ``skin`` relative to each other: |u_i - u_j| >= skin, with
u = x - x_build. The whole-bed rule (Allen & Tildesley, Computer Simulation of Liquids, 2nd ed.,
5.3) bounds |u_i - u_j| by 2 max |u| and rebuilds once any grain has moved skin / 2. Near a tool
the grains it pushes move together, so most of them move far less relative to their neighbours
than their own travel. With ``local`` on, `ListKeeper.must_build` keeps the list past skin / 2:

1. max |u| < skin / 2: the list is valid (the whole-bed rule).
2. max |u| >= skin: build (the plane and tool candidates of `reach.py` hold to one skin of
   travel, and the cell reach below assumes it).
3. otherwise, per cell of the build (the particles are in cell order, so a cell's grains are
   one index range), the box [lo_c, hi_c] of the u of its grains; for every cell holding a grain
   with |u| >= skin / 2 and every cell within s cells of it, s = ceil((2 r_max + 2 skin) / edge),
   the largest |u_i - u_j| the two boxes allow, sqrt(sum_d max(hi_c - lo_c', hi_c' - lo_c)_d^2),
   must stay below the skin; otherwise build.

Why that is enough: a pair of grains that both moved less than skin / 2 cannot have moved a skin
apart; a pair that touches now was at most r_i + r_j + |u_i - u_j| < 2 r_max + 2 skin apart at
the build, so its cells are at most s apart. So no contact is ever missed: the contacts, and so
the forces, are those of the whole-bed rule (the list differs, and lists built at other steps
put the particles in another cell order, so sums run in another order: equal to rounding).
States not in cell order (fewer than `Engine.REORDER_MIN` particles, or reordering off) keep the
whole-bed rule.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from dempath_sim.engine.neighbors import CellGrid

F64 = NDArray[np.float64]


@njit(parallel=True, cache=True)
def cell_boxes(pos, pos_build, cell_start, half_skin2, box, fast):  # pragma: no cover
    """Per cell c: box[c] = (lo (3,), hi (3,)) of the displacements u of its grains (lo > hi
    for an empty cell) and fast[c] = 1 if one of them moved at least skin / 2.

    Args:
        pos, pos_build: (n, 3) positions now and at the build [m], in the build's cell order.
        cell_start: (n_cells + 1,) first particle of each cell.
        half_skin2: (skin / 2)^2 [m^2].
        box: (n_cells, 6) out [m]; fast: (n_cells,) uint8 out.
    """
    for c in prange(cell_start.shape[0] - 1):
        lo0 = lo1 = lo2 = math.inf
        hi0 = hi1 = hi2 = -math.inf
        far = 0
        for i in range(cell_start[c], cell_start[c + 1]):
            u0 = pos[i, 0] - pos_build[i, 0]
            u1 = pos[i, 1] - pos_build[i, 1]
            u2 = pos[i, 2] - pos_build[i, 2]
            lo0 = min(lo0, u0)
            lo1 = min(lo1, u1)
            lo2 = min(lo2, u2)
            hi0 = max(hi0, u0)
            hi1 = max(hi1, u1)
            hi2 = max(hi2, u2)
            if u0 * u0 + u1 * u1 + u2 * u2 >= half_skin2:
                far = 1
        box[c, 0] = lo0
        box[c, 1] = lo1
        box[c, 2] = lo2
        box[c, 3] = hi0
        box[c, 4] = hi1
        box[c, 5] = hi2
        fast[c] = far


@njit(parallel=True, cache=True)
def cells_moved_apart(box, fast, dims, reach, skin2):  # pragma: no cover - compiled
    """Cells with a fast grain whose displacement box and that of a cell within ``reach``
    cells allow two grains |u_i - u_j| >= skin apart (rule 3 of the module doc), counted."""
    n_bad = 0
    for c in prange(fast.shape[0]):
        if not fast[c]:
            continue
        cz = c % dims[2]
        cy = (c // dims[2]) % dims[1]
        cx = c // (dims[1] * dims[2])
        bad = 0
        for ax in range(max(cx - reach, 0), min(cx + reach, dims[0] - 1) + 1):
            for ay in range(max(cy - reach, 0), min(cy + reach, dims[1] - 1) + 1):
                for az in range(max(cz - reach, 0), min(cz + reach, dims[2] - 1) + 1):
                    o = (ax * dims[1] + ay) * dims[2] + az
                    if box[o, 0] > box[o, 3]:
                        continue  # empty
                    d2 = 0.0
                    for d in range(3):
                        w = max(box[c, 3 + d] - box[o, d], box[o, 3 + d] - box[c, d])
                        d2 += w * w
                    if d2 >= skin2:
                        bad = 1
                        break
                if bad:
                    break
            if bad:
                break
        n_bad += bad
    return n_bad


class ListKeeper:
    """Decides at each step whether the neighbour list must be built again (module doc).

    Attributes:
        local: Keep the list past skin / 2 while the grains moved together (rule 3).
        kept_steps: Steps at which rule 3 kept a list the whole-bed rule would have rebuilt.
    """

    def __init__(self, skin: float, local: bool) -> None:
        """Args: the absolute skin [m] and whether rule 3 is used."""
        self.local = local
        self._skin = skin
        self._grid: CellGrid | None = None
        self._reach = 0
        self._box: F64 = np.zeros((0, 6))
        self._fast: NDArray[np.uint8] = np.zeros(0, np.uint8)
        self.kept_steps = 0

    def built(self, grid: CellGrid | None, r_max: float) -> None:
        """A list was built over ``grid`` (None: keep the whole-bed rule until the next one)."""
        self._grid = grid if self.local and grid is not None and grid.in_order else None
        if self._grid is None:
            return
        n_cells = len(self._grid.cell_start) - 1
        if len(self._fast) != n_cells:
            self._box = np.empty((n_cells, 6))
            self._fast = np.empty(n_cells, np.uint8)
        self._reach = math.ceil((2.0 * r_max + 2.0 * self._skin) / self._grid.cell)

    def must_build(self, moved: float, pos: F64, pos_build: F64) -> bool:
        """Whether to build now, given the largest displacement since the build ``moved`` [m]
        and the positions now and at the build (n, 3) [m]."""
        if moved <= 0.5 * self._skin:
            return False
        grid = self._grid
        if grid is None or moved >= self._skin:
            return True
        cell_boxes(pos, pos_build, grid.cell_start, 0.25 * self._skin ** 2, self._box,
                   self._fast)
        if cells_moved_apart(self._box, self._fast, grid.dims, self._reach, self._skin ** 2):
            return True
        self.kept_steps += 1
        return False
