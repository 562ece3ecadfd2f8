"""Giving each camera's tracks the scene's marker numbers: initial grid and epipolar geometry.

The markers are laid in the paper's grid (rows x columns, 50 mm apart, numbered row by row, row
0 on the tool axis; ``dempath_sim.scene.MarkerSpec``). In the first frame each camera's
detections are matched one to one to the grid projected through the calibration: the grid's
height above the calibration board and the markers' small offsets from their grid points are
unknown, so the projected grid is first shifted by the image translation on which most grid
points find a detection (a vote over all detection-minus-grid offsets), then
``linear_sum_assignment`` links them inside a gate.

A track that starts later (a marker that comes back where its lost track did not expect it) is
numbered from the other camera: among the markers this camera has not seen in this frame, the
one whose latest position in the other camera lies on this detection's epipolar line (within
``epipolar_px``) and is the only such candidate. Distances to the epipolar line are measured in
undistorted pixels (Hartley & Zisserman, Multiple View Geometry, 2nd ed., sec. 9.2).
"""

from __future__ import annotations

import logging
import math
from bisect import bisect_left
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from dempath_recon.methods.triangulate import Camera, undistort_normalized
from dempath_recon.tracking.two_view_kernel import two_view_linear

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class MarkerGrid:
    """The initial marker grid in the field frame (origin at the grid centre on the surface).

    Attributes:
        rows, columns: grid size (the paper: 3 x 5).
        spacing_x_m, spacing_z_m: grid pitch [m] (the paper: 0.05).
        side: +1 or -1, the side of the tool axis the further rows lie on (X direction).
        layout_m: explicit grid points ((x, y, z), ...) [m] for markers 1..n, field frame;
            when given it replaces the regular grid (e.g. a run's own grid points).
    """

    rows: int = 3
    columns: int = 5
    spacing_x_m: float = 0.05
    spacing_z_m: float = 0.05
    side: int = 1
    layout_m: tuple[tuple[float, float, float], ...] = ()

    def __post_init__(self) -> None:
        checks = {'rows': self.rows >= 1, 'columns': self.columns >= 1,
                  'spacing_x_m': 0 < self.spacing_x_m < 10,
                  'spacing_z_m': 0 < self.spacing_z_m < 10, 'side': self.side in (1, -1)}
        for name, ok in checks.items():
            if not ok:
                msg = f'{name}: out of range, got {getattr(self, name)!r}'
                raise ValueError(msg)

    @classmethod
    def from_scene(cls, scene: str) -> MarkerGrid:
        """The grid of a scene's ``markers:`` block (a scene file, or a shipped scene's name).

        The scene places row r at ``X = x_m + r * side * spacing_x_m`` and column c at
        ``Z = first_z_m + c * spacing_z_m``; the field frame's origin is the grid's centre, so
        only the size, the pitches and the side carry over.

        Raises:
            ReconstructionError: the scene cannot be read (the message names it and the fault).
        """
        from dempath_recon.errors import ReconstructionError
        from dempath_sim.errors import SceneError
        from dempath_sim.scene.loader import resolve_scene

        try:
            spec = resolve_scene(scene).markers
        except SceneError as err:
            msg = f'scene {scene!r}: {err}'
            raise ReconstructionError(msg) from err
        return cls(rows=spec.rows, columns=spec.columns, spacing_x_m=spec.spacing_x_m,
                   spacing_z_m=spec.spacing_z_m, side=spec.side)

    def points(self) -> tuple[NDArray[np.int32], FloatArray]:
        """Marker numbers (m,) and grid points (m, 3) m, numbered row by row from 1."""
        if self.layout_m:
            xyz = np.asarray(self.layout_m, np.float64).reshape(-1, 3)
            return np.arange(1, len(xyz) + 1, dtype=np.int32), xyz
        r, c = np.meshgrid(np.arange(self.rows), np.arange(self.columns), indexing='ij')
        numbers = (r * self.columns + c + 1).ravel().astype(np.int32)
        x = self.side * self.spacing_x_m * (r.ravel() - (self.rows - 1) / 2)
        z = self.spacing_z_m * (c.ravel() - (self.columns - 1) / 2)
        return numbers, np.column_stack([x, np.zeros_like(x), z])


def number_by_grid(camera: Camera, uv: FloatArray, grid: MarkerGrid, gate_px: float = 12.0,
                   wary: bool = False, shift_px: FloatArray | None = None,
                   ) -> tuple[NDArray[np.int32], FloatArray]:
    """Marker number of each detection (n, 2) px by the projected grid (-1 = none, or unsure).

    The projected grid is shifted by the image translation on which the grid points fit the
    detections best (each grid point scores ``1 - (d / gate_px)^2`` for its nearest detection
    within the gate, so the exact fit beats a fit shifted by one pitch where a camera sees the
    rows only a few pixels apart), then refined by the mean residual and matched one to one. A
    match is kept only when it is unambiguous: the detection's next-nearest grid point and the
    grid point's next-nearest detection are both at least ``gate_px / 2`` farther than the
    match. An unsure detection stays unnumbered (the other camera can number it later): a
    wrong number is worse than none. A ``wary`` fit numbers nothing when the grid shifted by
    one pitch (:func:`pitch_steps`) from the best fit scores within ``SHIFT_MARGIN`` of it:
    with an edge column or row missing the two fit alike, and the first of them may be one
    marker off for every spot (the numbering then waits for a frame that tells them apart).

    Returns:
        ``(numbers (n,), grid_uv (m, 2))``: the numbers and the shifted projected grid [px].
    """
    numbers, xyz = grid.points()
    proj = np.asarray(camera.project(xyz), np.float64)  # type: ignore[attr-defined]
    out = np.full(len(uv), -1, np.int32)
    if len(uv) == 0:
        return out, proj
    shift: FloatArray
    if shift_px is not None:  # placed by the caller (pair_anchor): no vote, no refinement
        shift = np.asarray(shift_px, np.float64).reshape(2)
    else:
        shift, wait = _voted_shift(proj, xyz, uv, gate_px, wary)
        if wait:
            return out, proj + shift  # a fit one pitch over scores nearly as well: wait
    cost = np.linalg.norm(proj[:, None, :] + shift - uv[None, :, :], axis=2)
    rows, cols = linear_sum_assignment(np.where(cost < gate_px, cost, 1e9))
    margin = gate_px / 2
    for r, c in zip(rows, cols, strict=True):
        if cost[r, c] >= gate_px:
            continue
        others_g = np.delete(cost[:, c], r)  # other grid points from this detection
        others_d = np.delete(cost[r, :], c)  # other detections from this grid point
        if (others_g >= cost[r, c] + margin).all() and (others_d >= cost[r, c] + margin).all():
            out[c] = numbers[r]
    return out, proj + shift


def _voted_shift(proj: FloatArray, xyz: FloatArray, uv: FloatArray, gate_px: float,
                 wary: bool) -> tuple[FloatArray, bool]:
    """(2,) px the image shift of the projected grid ``proj`` (m, 2) that the detections ``uv``
    (n, 2) vote for (:func:`number_by_grid`), refined by the matched points' mean residual, and
    whether a ``wary`` fit must wait (the grid one pitch over scores within ``SHIFT_MARGIN``;
    the shift is then the unrefined best one)."""
    offsets = (uv[:, None, :] - proj[None, :, :]).reshape(-1, 2)
    scores = grid_scores(proj[None, :, :] + offsets[:, None, :], uv, gate_px)
    first_best = int(np.argmax(scores))  # the first of equal scores, as a loop would keep
    best, shift = float(scores[first_best]), np.asarray(offsets[first_best], np.float64)
    steps = pitch_steps(proj, xyz)
    if wary and steps and float(grid_scores(
            proj[None, :, :] + shift + np.array(steps)[:, None, :], uv, gate_px).max()) \
            > best - SHIFT_MARGIN:
        return shift, True
    near = np.linalg.norm(proj[:, None, :] + shift - uv[None, :, :], axis=2)
    inside = near[near.min(axis=1) < gate_px]
    if len(inside):  # refine the shift by the matched points' residual
        shift = shift + np.mean(uv[inside.argmin(axis=1)] - (proj + shift)[near.min(axis=1)
                                                                           < gate_px], axis=0)
    return shift, False


SHIFT_MARGIN = 1.0  # a grid fit is refused when one shifted by a pitch scores within this much
# (one marker's worth) of it


def grid_scores(grid_uv: FloatArray, uv: FloatArray, gate_px: float) -> FloatArray:
    """(k,) how well each of k placements of the grid points (k, m, 2) px fits the detections
    (n, 2) px: each grid point scores ``1 - (d / gate_px)^2`` for its nearest detection within
    the gate. All placements in one array operation: the vote tries one per pair of a detection
    and a grid point (a few hundred a frame), one call each cost a tenth of the tracking's
    time."""
    d = np.sqrt(np.square(grid_uv[:, :, None, :] - uv[None, None, :, :]).sum(axis=3)).min(axis=2)
    return np.asarray(np.clip(1.0 - (d / gate_px) ** 2, 0.0, None).sum(axis=1), np.float64)


def pitch_steps(proj: FloatArray, xyz: FloatArray) -> list[FloatArray]:
    """The image steps (2,) px between neighbouring grid points (3D neighbours within 1.5
    times the grid's smallest spacing, in both directions), averaged per direction: the
    shifts by which a grid fit slips one pitch (on session 14's reddish look the side's grid,
    its edge marker lost, fitted one column over and numbered five spots one marker off)."""
    if len(xyz) < 2:
        return []
    d = np.linalg.norm(xyz[:, None] - xyz[None], axis=2)
    i, j = np.nonzero((d > 0) & (d <= 1.5 * d[d > 0].min()))
    steps3 = np.round((xyz[j] - xyz[i]) / d[d > 0].min(), 1)
    out = []
    for key in {tuple(k) for k in steps3.tolist()}:
        same = np.all(steps3 == key, axis=1)
        out.append(np.mean(proj[j[same]] - proj[i[same]], axis=0))
    return sorted(out, key=lambda v: (float(v[0]), float(v[1])))


_ESSENTIAL: dict[tuple[int, int], tuple[Camera, Camera, bytes, FloatArray]] = {}


def essential(cam_a: Camera, cam_b: Camera) -> FloatArray:
    """(3, 3) essential matrix with ``x_b^T E x_a = 0`` for normalised points of the two.

    Remembered per pair of camera objects and their poses (the epipolar checks ask it
    hundreds of times a frame for the same two cameras); a changed pose computes it anew."""
    sign = b''.join(np.asarray(a, np.float64).tobytes()
                    for a in (cam_a.R, cam_a.t, cam_b.R, cam_b.t))
    entry = _ESSENTIAL.get((id(cam_a), id(cam_b)))
    if entry is not None and entry[0] is cam_a and entry[1] is cam_b and entry[2] == sign:
        return entry[3]
    if len(_ESSENTIAL) >= 16:  # cameras of finished trackers
        _ESSENTIAL.clear()
    e = _essential(cam_a, cam_b)
    e.setflags(write=False)
    _ESSENTIAL[(id(cam_a), id(cam_b))] = (cam_a, cam_b, sign, e)
    return e


def _essential(cam_a: Camera, cam_b: Camera) -> FloatArray:
    """:func:`essential`, computed."""
    r_ab = cam_b.R @ cam_a.R.T
    t_ab = cam_b.t - r_ab @ cam_a.t
    tx = np.array([[0, -t_ab[2], t_ab[1]], [t_ab[2], 0, -t_ab[0]], [-t_ab[1], t_ab[0], 0]])
    return np.asarray(tx @ r_ab, np.float64)


MEMO_PIXELS = 4096  # undistorted pixels remembered per camera (a frame asks a few hundred)
_MEMO: dict[int, tuple[Camera, bytes, dict[tuple[float, float], tuple[float, float]]]] = {}


def normalised(cam: Camera, uv: FloatArray) -> FloatArray:
    """(n, 2) normalised image coordinates of pixels ``uv`` (n, 2) px of ``cam``:
    :func:`~dempath_recon.methods.projection.undistort_normalized`, each pixel undistorted once.

    The tracking rules ask the epipolar distance and the 3D point of the same few dozen
    detections many times a frame (45 OpenCV calls a frame on red clay at dusk, 0.5-1 ms,
    session 22); OpenCV undistorts each point on its own, so a remembered point is the value
    a new call gives. The memo holds ``MEMO_PIXELS`` pixels per camera (then starts again: a
    track's last points are asked again over the next frames, by the rules that follow it),
    is keyed by the camera object and its intrinsics (a changed K or distortion starts anew)
    and is emptied when a tracker starts (:func:`forget_pixels`).
    """
    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    sign = np.asarray(cam.K, np.float64).tobytes() + np.asarray(cam.dist, np.float64).tobytes()
    entry = _MEMO.get(id(cam))
    if entry is None or entry[0] is not cam or entry[1] != sign:
        if len(_MEMO) >= 16:  # cameras of finished trackers
            _MEMO.clear()
        entry = (cam, sign, {})
        _MEMO[id(cam)] = entry
    memo = entry[2]
    keys = [(p[0], p[1]) for p in uv.tolist()]
    missing = list(dict.fromkeys(k for k in keys if k not in memo))
    if missing:
        if len(memo) + len(missing) > MEMO_PIXELS:
            memo.clear()
        found = undistort_normalized(cam, np.array(missing, np.float64)).tolist()
        memo.update((k, (v[0], v[1])) for k, v in zip(missing, found, strict=True))
    return np.array([memo[k] for k in keys], np.float64).reshape(-1, 2)


def forget_pixels() -> None:
    """Empty :func:`normalised`'s memo: a tracker does when it starts, so a second pass over
    a recording (the bench's warm figure) pays as much as a running node does."""
    _MEMO.clear()


def epipolar_distance(cam_a: Camera, cam_b: Camera, uv_a: FloatArray,
                      uv_b: FloatArray) -> FloatArray:
    """(n, k) distance [px of camera b] of points (k, 2) in b from the lines of (n, 2) in a."""
    xa = normalised(cam_a, uv_a)
    xb = normalised(cam_b, uv_b)
    lines = np.column_stack([xa, np.ones(len(xa))]) @ essential(cam_a, cam_b).T  # (n, 3)
    hb = np.column_stack([xb, np.ones(len(xb))])
    num = np.abs(lines @ hb.T)
    den = np.hypot(lines[:, 0], lines[:, 1])[:, None]
    return np.asarray(num / np.maximum(den, 1e-12) * cam_b.K[0, 0], np.float64)


def on_epipolar_line(cam_a: Camera, cam_b: Camera, uv_a: FloatArray,
                     candidates: dict[int, FloatArray], epipolar_px: float = 4.0) -> list[int]:
    """The markers of ``candidates`` (number -> (2,) px in b) on ``uv_a``'s epipolar line."""
    if not candidates:
        return []
    nums = list(candidates)
    d = epipolar_distance(cam_a, cam_b, uv_a[None], np.array([candidates[n] for n in nums]))[0]
    return [int(nums[i]) for i in np.flatnonzero(d < epipolar_px)]


def number_by_epipolar(cam_a: Camera, cam_b: Camera, uv_a: FloatArray,
                       candidates: dict[int, FloatArray], epipolar_px: float = 4.0) -> int:
    """The one marker of ``candidates`` (number -> (2,) px in b) on ``uv_a``'s epipolar line.

    Returns -1 when none or more than one candidate lies within ``epipolar_px``.
    """
    close = on_epipolar_line(cam_a, cam_b, uv_a, candidates, epipolar_px)
    return close[0] if len(close) == 1 else -1


def triangulate_pairs(cam_a: Camera, cam_b: Camera, uv_a: FloatArray, uv_b: FloatArray,
                      ) -> tuple[FloatArray, FloatArray]:
    """3D points and epipolar distances of paired pixels.

    Args:
        cam_a, cam_b: the two cameras.
        uv_a, uv_b: (k, 2) px, row i of both the same marker (by its numbers).

    Returns:
        ``(xyz (k, 3) m, epipolar (k,) px)``: the linear triangulation (world frame) and the
        distance of each point in b from the epipolar line of its partner in a [px of b].
    """
    uv_a = np.asarray(uv_a, np.float64).reshape(-1, 2)
    uv_b = np.asarray(uv_b, np.float64).reshape(-1, 2)
    if len(uv_a) == 0:
        return np.zeros((0, 3)), np.zeros(0)
    xa, xb = normalised(cam_a, uv_a), normalised(cam_b, uv_b)
    xyz = _two_view_linear(cam_a, cam_b, xa, xb)
    lines = np.column_stack([xa, np.ones(len(xa))]) @ essential(cam_a, cam_b).T  # (k, 3)
    num = np.abs((lines * np.column_stack([xb, np.ones(len(xb))])).sum(axis=1))
    epi = num / np.maximum(np.hypot(lines[:, 0], lines[:, 1]), 1e-12) * cam_b.K[0, 0]
    return np.asarray(xyz, np.float64), np.asarray(epi, np.float64)


def depth(cam: Camera, xyz: FloatArray) -> float:
    """Depth [m] of a world point (3,) along the camera's optical axis."""
    return float((np.asarray(cam.R) @ np.asarray(xyz, np.float64) + np.asarray(cam.t))[2])


def marker_diameter_px(cam: Camera, grid: MarkerGrid, diameter_m: float) -> float:
    """A marker's diameter in ``cam``'s image [px]: ``f * D / Z`` at the median depth of the
    grid points (the markers start on them and stay within a few cm)."""
    _, xyz = grid.points()
    z = float(np.median([depth(cam, p) for p in xyz]))
    f = 0.5 * float(np.asarray(cam.K)[0, 0] + np.asarray(cam.K)[1, 1])
    return f * diameter_m / z if z > 0 else 0.0


def view_of_up(cam: Camera, grid: MarkerGrid) -> tuple[tuple[float, float], float]:
    """How ``cam`` sees world up (+Y) at the grid's median point: its image direction (a unit
    vector; (0, 0) when up looks along the line of sight) and the line of sight's elevation
    above the horizontal [degrees]. A partly buried marker's visible part lies up the image
    from its centre, by how much depends on that elevation (:mod:`.covered`)."""
    _, xyz = grid.points()
    p = np.median(np.asarray(xyz, np.float64), axis=0)
    a, b = project(cam, np.array([p, p + np.array([0.0, 0.01, 0.0])]))
    step = b - a
    norm = float(np.hypot(*step))
    centre = -np.asarray(cam.R, np.float64).T @ np.asarray(cam.t, np.float64).ravel()
    sight = p - centre
    elevation = float(np.degrees(np.arcsin(np.clip(-sight[1] / np.linalg.norm(sight), 0, 1))))
    up = (float(step[0] / norm), float(step[1] / norm)) if norm > 1e-6 else (0.0, 0.0)
    return up, elevation


def back_project(cam: Camera, uv: FloatArray, at_depth: float) -> FloatArray:
    """The world point (3,) m on the line of sight through ``uv`` (2,) px at a depth [m]."""
    xn = normalised(cam, uv)[0]
    local = at_depth * np.array([xn[0], xn[1], 1.0])
    return np.asarray(np.asarray(cam.R).T @ (local - np.asarray(cam.t)), np.float64)


def project(cam: Camera, xyz: FloatArray) -> FloatArray:
    """(k, 2) px of world points (k, 3) m in ``cam`` (lens distortion included)."""
    rvec, _ = cv2.Rodrigues(np.asarray(cam.R, np.float64))
    uv, _ = cv2.projectPoints(np.asarray(xyz, np.float64).reshape(-1, 1, 3), rvec,
                              np.asarray(cam.t, np.float64), np.asarray(cam.K, np.float64),
                              np.asarray(cam.dist, np.float64))
    return np.asarray(uv.reshape(-1, 2), np.float64)


def _two_view_linear(cam_a: Camera, cam_b: Camera, xa: FloatArray, xb: FloatArray,
                     reweight: int = 1) -> FloatArray:
    """(k, 3) m: the depth-reweighted linear triangulation of ``triangulate_points`` (no
    refinement) for normalised pairs (k, 2) of two cameras, compiled
    (:func:`~dempath_recon.tracking.two_view_kernel.two_view_linear`: the general n-camera form
    costs about a millisecond per call for a handful of pairs)."""
    return np.asarray(two_view_linear(
        np.ascontiguousarray(cam_a.R, np.float64), np.ascontiguousarray(cam_a.t, np.float64),
        np.ascontiguousarray(cam_b.R, np.float64), np.ascontiguousarray(cam_b.t, np.float64),
        np.ascontiguousarray(xa, np.float64).reshape(-1, 2),
        np.ascontiguousarray(xb, np.float64).reshape(-1, 2), reweight), np.float64)


CARRIED_MEMO = 4096  # answers of ``MarkerPositions.carried`` kept between two accepted positions
# (a frame asks a few hundred; a long stretch with no marker triangulated starts again)


class MarkerPositions:
    """Each marker's last accepted 3D position, and how far it can have moved since.

    A marker cannot move faster than ``max_speed_m_s`` (the markers ride on sand pushed by the
    tool); a pair of pixels whose triangulated point lies farther from the marker's last
    accepted position than ``gate_m + max_speed_m_s * dt`` cannot be that marker in both
    cameras: one of the two numbers is wrong. Markers never triangulated yet have no position
    and are not gated.

    Args:
        gate_m: allowance for triangulation noise, the cameras' exposure offset and the
            marker's size [m].
        max_speed_m_s: fastest a marker moves [m/s].
    """

    HISTORY = 200  # accepted positions kept per marker (a few seconds at 50 FPS per camera)

    def __init__(self, gate_m: float, max_speed_m_s: float) -> None:
        self.gate_m = gate_m
        self.max_speed_m_s = max_speed_m_s
        self.known: dict[int, tuple[float, FloatArray]] = {}
        self.history: dict[int, list[tuple[float, FloatArray]]] = {}  # the last HISTORY each
        self._times: dict[int, list[float]] = {}  # each history's stamps [s], in its order
        self._ordered: dict[int, bool] = {}  # whether those stamps never go back
        # :meth:`carried`'s answers since the last :meth:`accept` (the numbering rules ask it of
        # every missing marker, for each candidate pair, a dozen times a frame for one stamp)
        self._carried: dict[tuple[object, ...], FloatArray | None] = {}

    def distance(self, marker: int, stamp_s: float, xyz: FloatArray) -> tuple[float, float]:
        """``(distance, allowed)`` [m] of ``xyz`` (3,) from the marker's last position."""
        if marker not in self.known:
            return 0.0, np.inf
        t, ref = self.known[marker]
        allowed = self.gate_m + self.max_speed_m_s * abs(stamp_s - t)
        return float(np.linalg.norm(np.asarray(xyz) - ref)), allowed

    def allows(self, marker: int, stamp_s: float, xyz: FloatArray) -> bool:
        """Whether ``xyz`` (3,) m can be ``marker`` at ``stamp_s`` (always, if never seen)."""
        dist, allowed = self.distance(marker, stamp_s, xyz)
        return bool(np.isfinite(dist) and dist <= allowed)

    def accept(self, marker: int, stamp_s: float, xyz: FloatArray) -> None:
        """Record ``xyz`` (3,) m as the marker's position at ``stamp_s``."""
        if np.isfinite(xyz).all():
            self._carried.clear()
            self.known[marker] = (stamp_s, np.asarray(xyz, np.float64).copy())
            past = self.history.setdefault(marker, [])
            times = self._times.setdefault(marker, [])
            self._ordered[marker] = self._ordered.get(marker, True) and (
                not times or stamp_s >= times[-1])
            past.append(self.known[marker])
            times.append(stamp_s)
            del past[:-self.HISTORY]
            del times[:-self.HISTORY]

    def _nearest(self, marker: int, t_s: float) -> int:
        """The index of the first of ``marker``'s history entries nearest in time to ``t_s``
        (``min(past, key=|t - t_s|)``), by bisection while its stamps never went back (up to
        ``HISTORY`` entries per marker, asked for every other marker each time one is
        carried: the lambdas cost 0.6 ms a frame on a long look, session 21)."""
        times = self._times[marker]
        if not self._ordered[marker]:
            return min(range(len(times)), key=lambda i: abs(times[i] - t_s))
        i = bisect_left(times, t_s)
        if i == 0:
            return 0
        left = bisect_left(times, times[i - 1])  # the first of equal stamps
        if i == len(times) or abs(times[i - 1] - t_s) <= abs(times[i] - t_s):
            return left
        return i

    def carried(self, marker: int, stamp_s: float, near_s: float, recent_s: float,
                anchor: tuple[float, FloatArray] | None = None, neighbours: int = 3,
                ) -> FloatArray | None:
        """Where the bed's motion has carried a marker not seen since its last position.

        Its last accepted position, moved by the mean displacement, over the same interval, of
        the ``neighbours`` markers nearest to it then that have a position within ``near_s``
        of its last one and one at most ``recent_s`` old now (the bed moves as a continuum:
        a covered marker goes where the markers around it go). A marker never accepted starts
        from ``anchor`` ``(stamp s, (3,) m)`` if given. None when it has no position or no
        such neighbour.
        """
        key = (marker, stamp_s, near_s, recent_s, neighbours,
               None if anchor is None else (anchor[0], anchor[1].tobytes()))
        if key not in self._carried:
            if len(self._carried) >= CARRIED_MEMO:
                self._carried.clear()
            self._carried[key] = self._carry(marker, stamp_s, near_s, recent_s, anchor,
                                             neighbours)
        at = self._carried[key]
        return None if at is None else at.copy()

    def _carry(self, marker: int, stamp_s: float, near_s: float, recent_s: float,
               anchor: tuple[float, FloatArray] | None, neighbours: int) -> FloatArray | None:
        """:meth:`carried`, computed."""
        start = self.known.get(marker, anchor)
        if start is None:
            return None
        t_m, x_m = start
        moves = []
        for n, past in self.history.items():
            now = self.known[n]
            if n == marker or stamp_s - now[0] > recent_s or now[0] <= t_m:
                continue
            then = past[self._nearest(n, t_m)]
            if abs(then[0] - t_m) <= near_s:
                gap = then[1] - x_m  # its norm as np.linalg.norm takes it, without the checks
                moves.append((math.sqrt(float(gap.dot(gap))), now[1] - then[1]))
        if not moves:
            return None
        moves.sort(key=lambda mv: mv[0])
        return np.asarray(x_m + np.mean([mv[1] for mv in moves[:neighbours]], axis=0),
                          np.float64)
