"""Where the bed carried a marker no camera places now: a measured displacement field.

Several numbering rules name a marker by the place the bed has carried it to since its last
accepted 3D position (``state.carried_point``). The first rule (``MarkerPositions.carried``)
moved it by the mean displacement of its three nearest tracked neighbours, however far they
were. Against the truth of the ten long tuning looks (track34, docs/figures.md) that place was
worse than not moving the marker at all for markers away from the tool (median 28 mm against
9 mm after 0.2 s unseen, 60 mm or more from the tine): a neighbour one grid pitch (25 mm)
nearer the tine is pushed while the marker is not, and the plain mean hands it that push.

This module reads the same evidence as a smooth field with a still bed as its prior: the
displacement, over the marker's unseen interval, of every marker placed at both ends of it, each
weighted by a Gaussian of its offset from the marker's last place,
``w_i = exp(-sum_k d_ik^2 / (2 L_k^2))`` with the lengths ``L = KERNEL_M`` per axis (longer
along the travel, in which the tine pushes a strip of the bed), and a zero displacement weighted
``STILL_WEIGHT`` (Nadaraya-Watson kernel regression with a prior; the mean of a Gaussian process
with a squared-exponential kernel when the neighbours are far apart:
Rasmussen & Williams, Gaussian Processes for Machine Learning, 2006, sec. 2.2 and 2.6). Near the
tool the neighbours move together and their displacement is kept; away from it the nearest
neighbours are far and the still bed wins.

The place comes with a spread ``sigma_m``: the measured noise of a place (``BASE_SIGMA_M``),
the weighted spread of the neighbours' displacements (the field is not smooth there: the
tool's edge), the prior's share of the weights times the bed's largest measured motion
(no neighbour near: the place is a guess), and ``TIME_SIGMA_M_S`` times the time unseen, added
in quadrature. Twice the spread held the true place in about 90 % of the unseen marker-frames
of the tuning looks (docs/figures.md, track34). A rule can then accept or refuse on a distance
in spreads.

Only measured 3D positions are used (the DEM model being validated is never consulted).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
Placed = tuple[float, FloatArray]  # (stamp s, (3,) m)

KERNEL_M = (0.01, 0.02, 0.04)  # lengths of the field's Gaussian kernel along X (lateral), Y
# (up) and Z (travel) [m]: the tine pushes a strip of the bed along its travel, so markers in
# one lateral line move alike and a lateral neighbour one pitch (25 mm) off does not
# (ten long tuning looks: 7.1 mm median and 23.2 mm 90th percentile over all unseen
# marker-frames, against 7.3 / 26.9 mm for 15 mm in every direction; docs/figures.md)
STILL_WEIGHT = 0.3  # weight of the still bed's zero displacement, as of a neighbour 23 mm off
BASE_SIGMA_M = 0.003  # spread of a measured place (triangulation and the marker's size) [m]
TIME_SIGMA_M_S = 0.04  # growth of the spread with time unseen [m/s]: with it, twice the spread
# held the true place in 92 % (long) and 91 % (tiny) of the tuning looks' unseen marker-frames,
# against 89 % and 77 % without (docs/figures.md, track34)


class CarriedPlace(NamedTuple):
    """Where the bed carried a marker.

    Attributes:
        xyz: (3,) the place [m], world frame.
        sigma_m: its spread [m] (see the module docstring).
        since_s: stamp of the marker's last place the carry starts from [s].
        support: sum of the neighbours' kernel weights (0: the still bed alone).
    """

    xyz: FloatArray
    sigma_m: float
    since_s: float
    support: float


def neighbour_moves(history: Mapping[int, Sequence[Placed]], marker: int, start: Placed,
                    stamp_s: float, near_s: float, recent_s: float,
                    ) -> list[tuple[FloatArray, FloatArray]]:
    """``[(place then (3,) m, displacement (3,) m)]`` of the other markers over ``start``'s
    stamp -> now: each with a place within ``near_s`` of ``start``'s stamp and its latest one
    at most ``recent_s`` old at ``stamp_s`` and later than ``start``."""
    t_m = start[0]
    moves = []
    for n, past in history.items():
        if n == marker or not past:
            continue
        now = past[-1]
        if stamp_s - now[0] > recent_s or now[0] <= t_m:
            continue
        then = min(past, key=lambda p: abs(p[0] - t_m))
        if abs(then[0] - t_m) <= near_s:
            moves.append((then[1], now[1] - then[1]))
    return moves


def carry(start: Placed, moves: Sequence[tuple[FloatArray, FloatArray]], stamp_s: float,
          ) -> CarriedPlace:
    """The place the field ``moves`` (at least one; see :func:`neighbour_moves`) carries
    ``start`` to by ``stamp_s`` [s], with its spread (module docstring)."""
    t_m, x_m = start
    x_m = np.asarray(x_m, np.float64)
    then = np.array([m[0] for m in moves])
    step = np.array([m[1] for m in moves])
    scaled = (then - x_m) / np.asarray(KERNEL_M)
    w = np.exp(-0.5 * np.sum(np.square(scaled), axis=1))
    total = float(w.sum()) + STILL_WEIGHT
    moved = (w[:, None] * step).sum(axis=0) / total
    spread2 = float((w * np.sum(np.square(step - moved), axis=1)).sum() / total)
    guess = STILL_WEIGHT / total * float(np.max(np.linalg.norm(step, axis=1)))
    unseen = TIME_SIGMA_M_S * max(stamp_s - t_m, 0.0)
    sigma = float(np.sqrt(BASE_SIGMA_M**2 + spread2 + guess**2 + unseen**2))
    return CarriedPlace(x_m + moved, sigma, t_m, float(w.sum()))


def carried_place(history: Mapping[int, Sequence[Placed]], marker: int, stamp_s: float,
                  start: Placed | None, near_s: float, recent_s: float) -> CarriedPlace | None:
    """Where the bed carried ``marker`` from ``start`` (its last accepted place, or its grid
    point when never placed) by ``stamp_s``; None without a start or without a neighbour
    placed at both ends (as ``MarkerPositions.carried``: no measured motion to carry it by).

    Args:
        history: each marker's accepted places, oldest first (``MarkerPositions.history``).
        marker: the marker carried.
        stamp_s: now [s].
        start: ``(stamp s, (3,) m)`` the carry starts from.
        near_s: a neighbour's place counts as taken at ``start``'s stamp within this [s].
        recent_s: a neighbour's latest place counts as now within this [s].
    """
    if start is None:
        return None
    moves = neighbour_moves(history, marker, start, stamp_s, near_s, recent_s)
    return carry(start, moves, stamp_s) if moves else None
