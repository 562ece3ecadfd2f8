"""The markers' first numbers decided by both cameras at once: pairs of detections on each
other's epipolar lines, triangulated and matched to the grid in 3D.

One camera alone numbers its detections by the projected grid in the image, where an oblique
view packs the grid's rows close (13 px apart on a 25 mm grid seen from the side at 0.9 m) and
markers the bed has already moved sit 5-10 px from their grid points: on a tuning render of
another run one camera took marker 10 for 5 and the other 8 for 7, from the first frame to the
last. In 3D the same markers lie within 10 mm of their grid points, a third of the pitch.

So every pair (a detection of camera a, one of camera b) within ``epipolar_px`` of the other's
epipolar line is triangulated, the grid is shifted by the 3D offset most grid points agree on
(a vote, as the image grid is shifted in :func:`~dempath_recon.tracking.associate.number_by_grid`:
the grid's height above the calibration board is not known; shifts of half a pitch or more are
not tried, since a grid shifted by a pitch fits as well when markers are missing), and markers
and pairs are matched one to one by ``scipy.optimize.linear_sum_assignment`` on a cost of the
3D distance plus the epipolar distance (in units of their gates): camera a's detections first
(each marker's cheapest pair through each), then camera b's given a's, a marker left unmatched
when that is cheaper (``LEAVE``). A pair is a candidate only within ``GATE_SHARE`` of the grid's
pitch of its grid point and when no other grid point is nearly as near (``MARGIN_SHARE``); the
rest wait (a marker covered at the start is numbered later, by the epipolar line or as a pair).

A spot of one camera that pairs surely with two markers through different partners may be
both, merged along its line of sight (:func:`_two_markers`: left unnumbered). Before that test
each spot keeps only the marker whose partner lies on its epipolar line within noise
(``LINE_ON_SHARE``) and clearly nearer than every other's (``LINE_MARGIN_SHARE``,
:func:`_one_on_line`): two markers shown in one spot pull
its centre between their images, off both partners' lines alike, while a spot a marker hides
another behind, or a buried one beside, lies on its own partner's line within noise. (On the
longer pass with the tool twice as fast, the side's spots of markers 4 and 9 were called
merged with 9 and 14 while 14 lay buried behind 9, 0.24 px off 9's partner's line and 2.27 px
off 14's: both stayed unnumbered all pass, and numbered right fell from 83 to 71 %.)
"""

from __future__ import annotations

from collections import Counter
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import MarkerGrid, epipolar_distance, triangulate_pairs

FloatArray = NDArray[np.float64]
GATE_SHARE = 0.4  # a pair farther than this share of the grid's pitch from a grid point is not it
LEAVE = 2.0  # cost of leaving a marker unmatched: a pair at the gate and on the epipolar line's
# edge costs 2 (the 3D distance and the epipolar distance in units of their gates)
MAX_SHIFT_SHARE = 0.5  # the grid's 3D shift is below this share of the pitch
MARGIN_SHARE = 0.2  # the next grid point must be this share of the pitch farther than the nearest
LINE_MARGIN_SHARE = 0.4  # a spot is one marker's alone when the partners of its other sure
# markers lie this share of ``epipolar_px`` farther from its epipolar line than that marker's,
LINE_ON_SHARE = 0.2  # and that marker's lies within this share of it (on the line within noise)


def grid_pitch(grid: MarkerGrid) -> float:
    """The grid's smallest distance between two grid points [m]."""
    _, xyz = grid.points()
    if len(xyz) < 2:
        return float('inf')
    d = np.linalg.norm(xyz[:, None] - xyz[None], axis=2)
    return float(d[np.triu_indices(len(xyz), 1)].min())


class GridPairs(NamedTuple):
    """Both cameras' detections numbered by the grid fit."""

    a: NDArray[np.int32]  # (n,) camera a's detections' numbers (-1: none, unsure)
    b: NDArray[np.int32]  # (k,) camera b's
    merged_a: dict[int, set[int]]  # camera a's merged spots: detection -> the markers it holds
    merged_b: dict[int, set[int]]  # camera b's
    shift: FloatArray = np.zeros(3)  # (3,) the grid's fitted 3D offset [m]


def number_pairs_by_grid(cam_a: Camera, cam_b: Camera, uv_a: FloatArray, uv_b: FloatArray,
                         grid: MarkerGrid, epipolar_px: float,
                         ) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    """Marker numbers of camera a's (n, 2) and camera b's (k, 2) detections (-1: none,
    unsure): :func:`pairs_by_grid`'s numbers."""
    fit = pairs_by_grid(cam_a, cam_b, uv_a, uv_b, grid, epipolar_px)
    return fit.a, fit.b


def pairs_by_grid(cam_a: Camera, cam_b: Camera, uv_a: FloatArray, uv_b: FloatArray,
                  grid: MarkerGrid, epipolar_px: float) -> GridPairs:
    """Marker numbers of camera a's (n, 2) and camera b's (k, 2) detections (-1: none,
    unsure), and the merged spots left unnumbered (:func:`_two_markers`) with their markers.

    Args:
        cam_a, cam_b: the two cameras (world frame).
        uv_a, uv_b: the detections of one frame of each camera [px].
        grid: the marker grid (world frame, up to an unknown shift).
        epipolar_px: largest distance of a pair from the epipolar line [px].
    """
    out_a = np.full(len(uv_a), -1, np.int32)
    out_b = np.full(len(uv_b), -1, np.int32)
    numbers, g = grid.points()
    if not len(uv_a) or not len(uv_b) or not len(g):
        return GridPairs(out_a, out_b, {}, {})
    epi = epipolar_distance(cam_a, cam_b, uv_a, uv_b)
    ia, ib = np.nonzero(epi <= epipolar_px)
    if not len(ia):
        return GridPairs(out_a, out_b, {}, {})
    xyz, _ = triangulate_pairs(cam_a, cam_b, uv_a[ia], uv_b[ib])
    pitch = grid_pitch(grid)
    gate = GATE_SHARE * pitch
    shift = _shift(xyz, g, gate, pitch)
    dist = np.linalg.norm(xyz[None] - (g + shift)[:, None], axis=2)  # (markers, pairs)
    second = np.sort(dist, axis=0)[1] if len(g) > 1 else np.full(len(ia), np.inf)
    sure = (dist < gate) & (second[None] >= dist + MARGIN_SHARE * pitch)
    on_px, margin = LINE_ON_SHARE * epipolar_px, LINE_MARGIN_SHARE * epipolar_px
    held_a = _one_on_line(sure, ia, len(uv_a), epi[ia, ib], on_px, margin)
    held_b = _one_on_line(sure, ib, len(uv_b), epi[ia, ib], on_px, margin)
    merged_a, merged_b = _two_markers(held_a, ia, len(uv_a)), _two_markers(held_b, ib, len(uv_b))
    via = sure & (merged_a[ia] | merged_b[ib])[None]  # pairs through a merged spot
    cost = np.where(sure & ~via, dist / gate + epi[ia, ib][None] / epipolar_px, np.inf)
    # camera a's detections first (each marker's cheapest pair through each), then b's given a's
    side = _assign(np.stack([_cheapest(cost, ia == i) for i in range(len(uv_a))], axis=1))
    cost_b = np.full((len(g), len(uv_b)), np.inf)
    for m, i in side.items():
        through = np.flatnonzero(ia == i)
        cost_b[m, ib[through]] = cost[m, through]
    for m, j in _assign(cost_b).items():
        out_a[side[m]], out_b[j] = numbers[m], numbers[m]
    _number_beside_merged(via, ib, merged_b, sure, numbers, out_a, out_b)
    _number_beside_merged(via, ia, merged_a, sure, numbers, out_b, out_a)
    return GridPairs(out_a, out_b, _holds(held_a, ia, merged_a, numbers),
                     _holds(held_b, ib, merged_b, numbers), shift)


def _one_on_line(sure: NDArray[np.bool_], det: NDArray[np.int64], n: int, epi: FloatArray,
                 on_px: float, margin_px: float) -> NDArray[np.bool_]:
    """``sure`` (markers, pairs) with, for each of one camera's ``n`` detections (``det``:
    each pair's detection) whose nearest sure partner lies on its epipolar line (within
    ``on_px``; ``epi``: each pair's distance [px]) and every other sure marker's partner at
    least ``margin_px`` farther off, only that marker's pairs kept: the spot shows that marker
    alone (the others hidden behind or beside it), not two markers merged."""
    out = sure.copy()
    for i in range(n):
        through = np.flatnonzero(det == i)
        rows = np.flatnonzero(sure[:, through].any(axis=1))
        if len(rows) < 2:
            continue
        off = np.array([epi[through][sure[r, through]].min() for r in rows])
        order = np.argsort(off, kind='stable')
        if off[order[0]] <= on_px and off[order[0]] + margin_px <= off[order[1]]:
            out[np.ix_(rows[order[1:]], through)] = False
    return out


def _two_markers(sure: NDArray[np.bool_], det: NDArray[np.int64], n: int) -> NDArray[np.bool_]:
    """(n,) the detections of one camera (``det``: each pair's detection) that pair surely
    with two or more markers through different partners while this camera has fewer spots
    than markers among those that such spots could be: it sees those markers along one line
    of sight, merged in one spot, so the spot is either of them and is left to wait (a front
    spot of markers 9 and 10, one behind the other, took 10 at the fit on three tuning renders
    while it was 9's, for eight frames). Where each marker has its own spot (two spots on one
    line of sight, both pairing with both markers) the assignment decides."""
    holds = [set(np.flatnonzero(sure[:, det == i].any(axis=1)).tolist()) for i in range(n)]
    out = np.zeros(n, bool)
    for i in range(n):
        if len(holds[i]) >= 2:
            group = [h for h in holds if h & holds[i]]
            out[i] = len(set().union(*group)) > len(group)
    return out


def _number_beside_merged(via: NDArray[np.bool_], det: NDArray[np.int64],
                          merged: NDArray[np.bool_], sure: NDArray[np.bool_],
                          numbers: NDArray[np.int32], out_other: NDArray[np.int32],
                          out: NDArray[np.int32]) -> None:
    """Number in place (``out``) the unnumbered, unmerged detections of one camera (``det``:
    each pair's detection in it) whose only sure pairs run through the other camera's merged
    spot, all to one marker that no detection has taken and no other such detection could
    be: the merged spot holds that marker, and this clean spot is where it is (the side saw
    markers 9 and 10 apart, each on the front's merged spot's line at its own grid point).
    The merged spot itself stays unnumbered."""
    taken = set(out[out >= 0].tolist()) | set(out_other[out_other >= 0].tolist())
    claims: dict[int, list[int]] = {}
    for j in np.flatnonzero((out < 0) & ~merged).tolist():
        mine = det == j
        if via[:, mine].any() and not (sure[:, mine] & ~via[:, mine]).any():
            claims[j] = np.flatnonzero(sure[:, mine].any(axis=1)).tolist()
    wanted = Counter(r for rows in claims.values() for r in rows)
    for j, rows in claims.items():
        if len(rows) == 1 and wanted[rows[0]] == 1 and int(numbers[rows[0]]) not in taken:
            out[j] = numbers[rows[0]]


def _holds(sure: NDArray[np.bool_], det: NDArray[np.int64], merged: NDArray[np.bool_],
           numbers: NDArray[np.int32]) -> dict[int, set[int]]:
    """Each merged detection's markers (the numbers of its sure pairs)."""
    return {i: {int(numbers[r]) for r in np.flatnonzero(sure[:, det == i].any(axis=1))}
            for i in np.flatnonzero(merged).tolist()}


def _cheapest(cost: FloatArray, among: NDArray[np.bool_]) -> FloatArray:
    """(markers,) each marker's cheapest cost among the pairs ``among`` (inf: none)."""
    return np.asarray(cost[:, among].min(axis=1) if among.any() else
                      np.full(len(cost), np.inf), np.float64)


def _assign(cost: FloatArray) -> dict[int, int]:
    """marker row -> detection column, one to one (``linear_sum_assignment``), a marker left
    without a detection when that costs less than its cheapest possible link (``LEAVE``)."""
    n, k = cost.shape
    full = np.full((n, k + n), np.inf)
    full[:, :k] = cost
    full[np.arange(n), k + np.arange(n)] = LEAVE
    rows, cols = linear_sum_assignment(np.where(np.isfinite(full), full, 1e6))
    return {int(r): int(c) for r, c in zip(rows, cols, strict=True)
            if c < k and np.isfinite(cost[r, c])}


def _shift(xyz: FloatArray, grid_xyz: FloatArray, gate: float, pitch: float) -> FloatArray:
    """(3,) the 3D offset of the grid on which most grid points find a pair within ``gate``,
    refined by the mean residual of those pairs."""
    offsets = np.vstack([np.zeros((1, 3)), (xyz[None] - grid_xyz[:, None]).reshape(-1, 3)])
    # the grid repeats itself: a shift by a pitch fits as well when markers are missing, so
    # only shifts below half a pitch are tried (the grid's height is known to a few mm)
    offsets = offsets[np.linalg.norm(offsets, axis=1) < MAX_SHIFT_SHARE * pitch]
    # (offsets, grid points, pairs): each grid point's nearest pair under each offset
    d = np.linalg.norm(grid_xyz[None, :, None] + offsets[:, None, None] - xyz[None, None],
                       axis=3).min(axis=2)
    score = np.clip(1.0 - (d / gate) ** 2, 0.0, None).sum(axis=1)
    shift = offsets[int(np.argmax(score))]  # the first of equal scores: the same every run
    d = np.linalg.norm(grid_xyz[:, None] + shift - xyz[None], axis=2)
    near = d.min(axis=1) < gate
    if near.any():
        shift = shift + np.mean(xyz[d.argmin(axis=1)[near]] - (grid_xyz[near] + shift), axis=0)
    return np.asarray(shift, np.float64)
