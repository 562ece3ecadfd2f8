# mypy: disable-error-code="no-untyped-def"
"""Which particles the plane and tool pass must test: reach lists built at each list build.

A particle farther than its reach from every plane and from the tool's box cannot touch them
before the next neighbour-list build (or before the tool has moved beyond the margin, which
:func:`box_displacement` measures), so the boundary pass skips it.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from dempath_sim.engine.boundary import plane_distance, to_tool_frame

# (8, 3) corner k of a box takes hi on axis a where bit a of k is set, lo elsewhere.
CORNER_BITS = np.array([[(k >> a) & 1 for a in range(3)] for k in range(8)], np.bool_)


@njit(cache=True)
def reach_candidates(pos_build, rad, planes, plane_reach, tool_ref, g_lo, g_hi, tool_reach,
                     gkey, ght, ghr, keep):  # pragma: no cover - compiled
    """Mark the particles that may touch a plane or the tool; clear the others' history slots.

    A particle within plane_reach + r of a plane, or whose centre lies within tool_reach of the
    triangle grid's box (tool frame of the pose tool_ref), both at the build positions, is kept.
    With particles at most d from pos_build and tool points at most D from their place at
    tool_ref, plane_reach >= d and tool_reach >= d + D make the others unable to touch: their
    slots would be cleared by the full pass this step, so they are here. The engine passes
    plane_reach = skin and tool_reach = skin + D: d is skin / 2 under the whole-bed rebuild
    rule and below one skin with the kept list of `rebuild.py`.

    Args:
        pos_build: (n, 3) positions at the neighbour-list build [m]; rad: (n,) radii [m].
        planes: (n_planes, 6) point and inward unit normal.
        plane_reach, tool_reach: Margins [m] (see above); tool_reach < 0: no tool.
        tool_ref: (18,) packed tool pose (see boundary_forces).
        g_lo, g_hi: (3,) triangle grid box in the tool frame [m].
        gkey, ght, ghr: History slots (see boundary_forces), cleared for the dropped particles.
        keep: (n,) bool out.
    """
    for i in range(pos_build.shape[0]):
        near = False
        for p in range(planes.shape[0]):
            s = plane_distance(planes, p, pos_build[i, 0], pos_build[i, 1], pos_build[i, 2])
            if s < rad[i] + plane_reach:
                near = True
                break
        if not near and tool_reach >= 0.0:
            px, py, pz = to_tool_frame(tool_ref, pos_build[i, 0], pos_build[i, 1],
                                       pos_build[i, 2])
            near = (g_lo[0] - tool_reach <= px <= g_hi[0] + tool_reach
                    and g_lo[1] - tool_reach <= py <= g_hi[1] + tool_reach
                    and g_lo[2] - tool_reach <= pz <= g_hi[2] + tool_reach)
        keep[i] = near
        if not near:
            for k in range(gkey.shape[1]):
                if gkey[i, k] != -1:
                    gkey[i, k] = -1
                    for q in range(3):
                        ght[i, k, q] = 0.0
                        ghr[i, k, q] = 0.0


def box_corners(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.float64]:
    """(8, 3) corners of the box [lo, hi] [m], corner k taking hi on the axes set in bit k."""
    return np.where(CORNER_BITS, np.asarray(hi, np.float64), np.asarray(lo, np.float64))


def box_displacement(corners: NDArray[np.float64], pose_a: NDArray[np.float64],
                     pose_b: NDArray[np.float64]) -> float:
    """Largest distance a point of a box (tool frame) moves between two poses [m].

    The displacement (R_b - R_a) p + t_b - t_a is affine in p, so its largest norm over the box
    is reached at a corner.

    Args:
        corners: (8, 3) corners of the box in the tool frame [m] (see `box_corners`).
        pose_a, pose_b: (18,) packed tool poses (see boundary_forces).
    """
    rot_a = pose_a[9:18].reshape(3, 3)
    rot_b = pose_b[9:18].reshape(3, 3)
    moved = corners @ (rot_b - rot_a).T + (pose_b[:3] - pose_a[:3])
    return float(np.sqrt((moved * moved).sum(axis=1).max()))


class BoundaryCandidates:
    """The particles the plane/tool pass tests, kept from one neighbour-list build to the next.

    Found at the build positions (``reach_candidates``) and again when the tool has moved more
    than ``margin`` since they were found; ``forget`` after every list build.
    """

    def __init__(self, planes: NDArray[np.float64], skin: float, margin: float,
                 tool_box: tuple[NDArray[np.float64], NDArray[np.float64]] | None) -> None:
        """Args: packed planes, the skin [m], the tool travel one set covers [m], and the
        tool's triangle-grid box (lo, hi) in its own frame [m] (None: no tool)."""
        self._planes = planes
        self._skin = skin
        self._margin = margin
        self._box = tool_box
        self.corners = box_corners(*(tool_box or (np.zeros(3), np.zeros(3))))  # tool frame
        self._idx: NDArray[np.int64] | None = None  # None: to be found
        self._ref: NDArray[np.float64] = np.zeros(18)  # tool pose they were found for

    @property
    def indices(self) -> NDArray[np.int64] | None:
        """The particles found last (None: to be found at the next call)."""
        return self._idx

    @property
    def pose(self) -> NDArray[np.float64]:
        """The packed tool pose they were found for."""
        return self._ref

    def forget(self) -> None:
        """Find them afresh at the next call (a list build moved the build positions)."""
        self._idx = None

    def particles(self, pos_build: NDArray[np.float64], radii: NDArray[np.float64],
                  packed: NDArray[np.float64], gkey: NDArray[np.int32],
                  ght: NDArray[np.float64], ghr: NDArray[np.float64]) -> NDArray[np.int64]:
        """Indices of the particles to test at the tool pose ``packed``; the history slots of
        the particles dropped are cleared (see ``reach_candidates``)."""
        if (self._box is not None and self._idx is not None and packed is not self._ref
                and box_displacement(self.corners, self._ref, packed) > self._margin):
            self._idx = None  # the tool left the reach of these candidates
        if self._idx is None:
            keep = np.empty(len(radii), np.bool_)
            lo, hi, reach = ((*self._box, self._skin + self._margin) if self._box is not None
                             else (np.zeros(3), np.zeros(3), -1.0))
            reach_candidates(pos_build, radii, self._planes, self._skin, packed, lo, hi, reach,
                             gkey, ght, ghr, keep)
            self._idx = np.flatnonzero(keep)
            self._ref = packed
        return self._idx
