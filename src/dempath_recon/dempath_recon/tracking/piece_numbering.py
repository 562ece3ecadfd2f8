"""Numbering over the whole pass by pieces: every unnumbered stretch of a 2D track, in either
camera, paired in 3D where both cameras have one and numbered by one assignment on how well it
continues each marker's path.

:func:`~dempath_recon.tracking.whole_pass.number_whole_pass` numbers only tracks that no frame
numbered; what stays unnumbered on unseen looks is mostly elsewhere (session 24's census on 16
burnt looks: of the found-but-unnumbered marker-frames, 52 % belong to a marker the other
camera does not see then, 28 % to a stretch of a track numbered as another marker before or
after, its links having moved, 26 % to a track numbered as this marker elsewhere; 55 % lie in
stretches of six frames or more). A marker moves with the sand and cannot jump, so a stretch
of track that starts where a marker's numbered path was carried to, and ends where it comes
back, is that marker, whether or not the other camera sees it. :func:`number_pieces`:

1. **Pieces**: each camera's unnumbered points, by 2D track, cut where the track has a
   numbered point, comes back after a gap or jumps
   (:func:`~dempath_recon.tracking.whole_pass.smooth_pieces`), of at least ``MIN_POINTS``
   points (:func:`unnumbered_pieces`).
2. **3D pieces**: the two cameras' pieces paired by one assignment on their median distance
   from each other's epipolar line over their common stretch (the other piece interpolated to
   each stamp: the cameras do not expose at the same instant), with the whole-pass margin,
   kept only when the pair fits both ways (:func:`pair_pieces`).
3. **One assignment** of the units (3D pieces and the pieces left alone) to the markers that
   no camera of the unit gives out over its stretch, on the largest share of what a marker can
   move (:func:`~dempath_recon.tracking.whole_pass.continuity`: each end against the
   marker's own numbered points that side, carried by their velocity, in each camera and in
   3D). A single-camera piece whose stretch the other camera's numbered points of the marker
   cover is scored by them too: off their epipolar line it cannot be that marker, on it its
   3D points must continue the path (:func:`unit_cost`). A unit may take a marker only when it
   comes in where the marker's own points in each camera carried it, within a marker's
   diameter and a few frames (:func:`lands`), starting with the pass, nearest its fitted
   grid point (:func:`first_at_grid`), when its own 2D track carries no other number right
   beside it (:func:`track_bounds`), and, a piece alone, when no other marker's own point
   lies within a diameter of it (:func:`touched`); it takes it only when its share is at
   most 1 and every other marker's share for it, and every other unit's over the same
   instants for that marker, is ``MARGIN_SHARE`` times worse (:func:`clear`): two fits, no
   number.
4. **By the other camera's lines**: each camera's pieces then against the other camera's
   numbered points, as the whole pass numbers never-numbered tracks, but a piece bounded by
   another number of its own track (:func:`by_lines`).
5. Never a number its frame gives out, nor one a rule withheld there on evidence from the
   frame (:func:`~dempath_recon.tracking.joint_fill.withheld`); ``ROUNDS`` rounds, each on the
   numbers the round before gave (a marker hidden twice gets its second stretch once the
   first is its own).

On 16 burnt looks (session 24) this numbered 86.91 -> 87.64 % right, switches 29 -> 30,
wrong-pair points 9 -> 9 (docs/figures.md). What it leaves: markers a camera never numbered
in the whole pass (no own points there to continue: 62 % of what stays found and
unnumbered), which only the bed's motion could place.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.joint_fill import withheld
from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.trajectories import interpolate_history, marker_histories
from dempath_recon.tracking.whole_pass import (
    JUMP_PX,
    MARGIN_SHARE,
    START_FRAMES,
    Assignment,
    PairFit,
    Pass,
    Track,
    by_other_numbers,
    end_gaps,
    lacks,
    marker_points_3d,
    pair_tracklets,
    smooth_pieces,
)

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
MIN_POINTS = 2  # a piece of fewer points [frames] says too little of where it goes
REACH_FRAMES = 4  # a unit must come in within this many frames of its marker's own numbered
# points in a camera [frames] (farther, one time in three another marker on the tuning looks)
ROUNDS = 4  # rounds, each on the numbers the round before gave (a marker's second stretch)


class Unit(NamedTuple):
    """What one number goes to: one piece, or a piece of each camera paired in 3D.

    Attributes:
        pieces: the pieces (one or two cameras).
        shared: per piece, (k,) which of its points may take the number.
        fit: the pair's fit (a 3D piece: the first piece against the second), else None.
    """

    pieces: tuple[Track, ...]
    shared: tuple[NDArray[np.bool_], ...]
    fit: PairFit | None

    def span(self) -> tuple[float, float]:
        """The first and last stamp of the unit [s]."""
        return (min(p.times[0] for p in self.pieces), max(p.times[-1] for p in self.pieces))


def unnumbered_pieces(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                      camera: str, fps: float) -> list[Track]:
    """``camera``'s unnumbered points, by 2D track, as pieces: cut at the track's numbered
    points (a stretch between two of its numbers), after a gap and where it jumps
    (:func:`~dempath_recon.tracking.whole_pass.smooth_pieces`); the pieces of at least
    ``MIN_POINTS`` points, by track id then time."""
    rows: dict[int, list[tuple[float, float, float, int, int, int]]] = {}
    for i, (f, ids) in enumerate(zip(frames, track_ids, strict=True)):
        if f.camera != camera:
            continue
        for k, (m, tid) in enumerate(zip(f.markers.tolist(), ids.tolist(), strict=True)):
            u, v = (float(x) for x in f.uv[k])
            rows.setdefault(int(tid), []).append((f.stamp_s, u, v, i, k, int(m)))
    out: list[Track] = []
    for tid, rs in sorted(rows.items()):
        rs.sort()
        runs: list[list[tuple[float, float, float, int, int, int]]] = [[]]
        for r in rs:
            if r[5] >= 0:
                runs.append([])
            else:
                runs[-1].append(r)
        n = 0
        for run in runs:
            if len(run) < MIN_POINTS:
                continue
            times, uv = np.array([r[0] for r in run]), np.array([r[1:3] for r in run])
            where = np.array([r[3:5] for r in run], np.int64)
            for p in smooth_pieces(times, uv, fps):
                if len(p) >= MIN_POINTS:
                    out.append(Track(camera, tid, n, times[p], uv[p], where[p]))
                    n += 1
    return out


def track_bounds(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                 piece: Track, fps: float) -> frozenset[int]:
    """The numbers the piece's own 2D track carries right before and right after it (within
    1.5 frame periods, linked without a jump: the point is within ``JUMP_PX`` of where the
    piece's first or last two points carry it back or on). The 2D link says the piece is that
    marker's; a piece bounded so is no other marker's (on the tuning looks such a piece,
    continuing a neighbour's carried point as well, was the track's own marker)."""
    rows = sorted((f.stamp_s, int(f.markers[k]), f.uv[k])
                  for f, ids in zip(frames, track_ids, strict=True) if f.camera == piece.camera
                  for k in np.flatnonzero(ids == piece.track_id).tolist())
    out = set()
    for end, step in ((0, -1), (len(piece.times) - 1, 1)):
        t_end = piece.times[end]
        near = [r for r in rows if 0 < step * (r[0] - t_end) <= 1.5 / fps]
        if not near or near[0 if step > 0 else -1][1] < 0:
            continue
        t_n, m, uv_n = near[0 if step > 0 else -1]
        carried = piece.uv[end]
        if len(piece.times) > 1:
            j = end - step
            velocity = (piece.uv[end] - piece.uv[j]) / (piece.times[end] - piece.times[j])
            carried = carried + velocity * (t_n - t_end)
        if float(np.linalg.norm(uv_n - carried)) <= JUMP_PX:
            out.add(m)
    return frozenset(out)


def pair_pieces(ps: Pass, pieces: dict[str, list[Track]]) -> tuple[list[Unit], list[Unit]]:
    """The 3D pieces (:func:`~dempath_recon.tracking.whole_pass.pair_tracklets`: one
    assignment on the median epipolar distance, with the whole-pass margin, fitting both
    ways) and the pieces left alone, as units."""
    pairs = [Unit(both, checked, fit) for both, checked, fit in pair_tracklets(ps, pieces)]
    used = {id(p) for u in pairs for p in u.pieces}
    alone = [Unit((p,), (np.ones(len(p.times), bool),), None)
             for c in sorted(ps.cameras) for p in pieces[c] if id(p) not in used]
    return pairs, alone


def unit_cost(ps: Pass, unit: Unit, marker: int,
              ) -> tuple[float, tuple[NDArray[np.bool_], ...]]:
    """``unit``'s share for ``marker`` (:func:`~dempath_recon.tracking.whole_pass.continuity`;
    inf: it cannot be it or nothing says) and the points of each piece that may take it: a 3D
    piece's as the whole pass scores a tracklet; a piece alone whose stretch the other
    camera's numbered points of the marker cover (at least ``MIN_POINTS`` of its stamps) must
    lie on their epipolar lines (its 3D points then count too, and the points off the line
    keep no number)."""
    for p in unit.pieces:
        if not lacks(ps.own_2d[p.camera], marker, p.times, ps.fps):
            return np.inf, unit.shared
    pieces = {p.camera: (p.times, p.uv) for p in unit.pieces}
    if unit.fit is not None:
        ok = unit.shared[0]
        xyz = (unit.pieces[0].times[ok], unit.fit.xyz[ok])
        return ps.share(pieces, xyz, marker), unit.shared
    piece = unit.pieces[0]
    theirs = ps.own_2d[ps.other(piece.camera)].get(marker)
    other_uv = None if theirs is None else interpolate_history(theirs, piece.times,
                                                                1.5 / ps.fps)
    fit = None if other_uv is None else ps.fit(piece, other_uv)
    if fit is None:  # the other camera's points cover too few of its stamps: its camera alone
        return ps.share(pieces, None, marker), unit.shared
    if not fit.fits:
        return np.inf, unit.shared
    ok = fit.checked
    return ps.share(pieces, (piece.times[ok], fit.xyz[ok]), marker), (fit.checked,)


def lands(ps: Pass, unit: Unit, marker: int, diameter_px: dict[str, float]) -> bool:
    """Whether ``unit`` comes in where ``marker``'s own numbered points in each camera carried
    it (:func:`~dempath_recon.tracking.whole_pass.end_gaps`): every end of a piece that has
    them within a marker's diameter (``diameter_px``: camera -> px) of that point, and at
    least one within ``REACH_FRAMES`` of them. The continuity share's gate grows with the
    time between (a marker may speed up), and far from its last point another marker may
    have come there: on the tuning looks single-camera pieces 10-25 px off their marker's
    carried point, or 5-12 frames from it, were the marker one time in three."""
    near = False
    for p in unit.pieces:
        if not first_at_grid(ps, p, marker) or (unit.fit is None and touched(ps, p, marker,
                                                                             diameter_px)):
            return False
        own = ps.own_2d[p.camera].get(marker)
        gaps = None if own is None else end_gaps(p.times, p.uv, own)
        if not gaps:
            continue
        if max(d for d, _ in gaps) > diameter_px[p.camera]:
            return False
        near |= min(dt for _, dt in gaps) <= (REACH_FRAMES + 0.5) / ps.fps
    return near


def touched(ps: Pass, piece: Track, marker: int, diameter_px: dict[str, float]) -> bool:
    """Whether another marker's own numbered point in the piece's camera, within
    ``REACH_FRAMES`` of one of its points, lies within a marker's diameter of it: two markers
    that close cannot be told apart in one camera by where they went (on the tuning looks a
    sinking marker's track slid onto a neighbour coming out beside it, 4 px a frame, and its
    stretch continued the sinking marker's path)."""
    reach = (REACH_FRAMES + 0.5) / ps.fps
    for other, (times, uv) in ps.own_2d[piece.camera].items():
        if other == marker:
            continue
        for t, at in zip(piece.times, piece.uv, strict=True):
            close = np.abs(times - t) <= reach
            if close.any() and float(np.min(np.linalg.norm(uv[close] - at, axis=1))) \
                    <= diameter_px[piece.camera]:
                return True
    return False


def first_at_grid(ps: Pass, piece: Track, marker: int) -> bool:
    """Whether a piece that starts with the pass (within ``START_FRAMES`` frames) starts
    nearer ``marker``'s fitted grid point than ``MARGIN_SHARE`` times any other marker's
    not given out in its first frame: the grid fit left it unnumbered there (on the tuning
    looks, a spot two markers shared at the start, numbered once they parted), and where the
    pass began says which it is. A piece that starts later, or a camera without the grid: no
    objection."""
    grid = ps.grid_uv.get(piece.camera, {})
    if marker not in grid or piece.times[0] - ps.start_s > (START_FRAMES + 0.5) / ps.fps:
        return True
    given = {m for m, (t, _) in ps.own_2d[piece.camera].items()
             if np.any(np.abs(t - piece.times[0]) < 0.5 / ps.fps)}
    d = {m: float(np.linalg.norm(piece.uv[0] - g)) for m, g in grid.items()
         if m == marker or m not in given}
    return all(v >= MARGIN_SHARE * d[marker] for m, v in d.items() if m != marker)


def clear(cost: FloatArray, spans: list[tuple[float, float]], row: int, col: int) -> bool:
    """Whether unit ``row``'s share for marker ``col`` is clearly the best: every other share
    of its row, and of its column among the units overlapping it in time (one marker cannot
    be two of them; units apart in time may each be a stretch of it), at least
    ``MARGIN_SHARE`` times it."""
    best = cost[row, col]
    t0, t1 = spans[row]
    over = [r for r, (a, b) in enumerate(spans) if r != row and a <= t1 and b >= t0]
    others = np.concatenate([np.delete(cost[row], col), cost[over, col]])
    others = others[np.isfinite(others)]
    return not len(others) or bool(others.min() >= MARGIN_SHARE * best)


def by_continuity(ps: Pass, frames: Sequence[PixelFrame],
                  track_ids: Sequence[NDArray[np.int64]], pieces: dict[str, list[Track]],
                  grid: set[int], diameter_px: dict[str, float]) -> list[Assignment]:
    """The units (3D pieces and pieces alone) numbered by one assignment on their continuity
    shares, the clear ones (module docstring, step 3)."""
    from scipy.optimize import linear_sum_assignment

    pairs, alone = pair_pieces(ps, pieces)
    units = pairs + alone
    markers = sorted(grid | set(ps.own_3d) | {m for h in ps.own_2d.values() for m in h})
    if not units or not markers:
        return []
    gate = np.zeros((len(units), len(markers)), bool)  # may take it, share aside
    for i, u in enumerate(units):
        bounds = frozenset().union(*(track_bounds(frames, track_ids, p, ps.fps)
                                     for p in u.pieces))
        for j, m in enumerate(markers):
            gate[i, j] = not bounds - {m} and lands(ps, u, m, diameter_px)
    if not gate.any():
        return []
    # the shares where a gate is open, and of their rows and columns (the rivals: clear)
    cost = np.full(gate.shape, np.inf)
    takes: dict[tuple[int, int], tuple[NDArray[np.bool_], ...]] = {}
    rows_open = np.asarray(gate.any(axis=1), bool)
    cols_open = np.asarray(gate.any(axis=0), bool)
    for i, j in zip(*np.nonzero(rows_open[:, None] | cols_open[None, :]), strict=True):
        cost[i, j], takes[int(i), int(j)] = unit_cost(ps, units[i], markers[j])
    allowed = gate & (cost <= 1)
    if not allowed.any():
        return []
    rows, cols = linear_sum_assignment(np.where(allowed, cost, 1e6))
    spans = [u.span() for u in units]
    return [Assignment(markers[c], units[r].pieces, takes[r, c], 'pieces')
            for r, c in zip(rows.tolist(), cols.tolist(), strict=True)
            if allowed[r, c] and clear(cost, spans, r, c)]


def by_lines(ps: Pass, frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
             pieces: dict[str, list[Track]]) -> list[Assignment]:
    """Each camera's pieces numbered by the other camera's numbered points on their epipolar
    lines (:func:`~dempath_recon.tracking.whole_pass.by_other_numbers` on pieces, the other
    camera's pieces as rivals), as the whole pass numbers whole tracks; but a piece whose own
    track carries another number right beside it (:func:`track_bounds`)."""
    found = []
    for cam in sorted(ps.cameras):
        found += [a for a in by_other_numbers(ps, cam, pieces[cam], pieces[ps.other(cam)])
                  if not any(track_bounds(frames, track_ids, p, ps.fps) - {a.marker}
                             for p in a.tracks)]
    return found


def number_round(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                 cameras: dict[str, Camera], grid_uv: dict[str, dict[int, FloatArray]],
                 epipolar_px: float, fps: float, grid: set[int], diameter_px: dict[str, float],
                 ) -> tuple[list[PixelFrame], int]:
    """One round of :func:`number_pieces` on the numbers as they are: the frames with the
    numbers by continuity, then by the other camera's lines, and how many points got one."""
    names = sorted(cameras)
    ps = Pass(cameras, {c: marker_histories(list(frames), c) for c in names},
              marker_points_3d(frames, cameras, fps), grid_uv,
              min(f.stamp_s for f in frames), epipolar_px, fps)
    pieces = {c: unnumbered_pieces(frames, track_ids, c, fps) for c in names}
    found = by_continuity(ps, frames, track_ids, pieces, grid, diameter_px) \
        + by_lines(ps, frames, track_ids, pieces)
    out = [f.markers.copy() for f in frames]
    given = 0
    for a in found:
        for piece, ok in zip(a.tracks, a.shared, strict=True):
            for i, k in piece.where[ok].tolist():
                if a.marker not in out[i] and out[i][k] < 0 and not withheld(frames[i], a.marker):
                    out[i][k] = a.marker
                    given += 1
        LOG.info('pieces (%s): %s numbered %d', a.step, '+'.join(
            f'{p.camera} track {p.track_id} at {p.times[0]:.3f}-{p.times[-1]:.3f} s'
            for p in a.tracks), a.marker)
    return [f._replace(markers=m) for f, m in zip(frames, out, strict=True)], given


def number_pieces(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                  cameras: dict[str, Camera], grid_uv: dict[str, dict[int, FloatArray]],
                  diameter_px: dict[str, float], epipolar_px: float, fps: float,
                  ) -> tuple[list[PixelFrame], int]:
    """The pass's frames (both cameras, as they would be given out; ``track_ids`` (k,) each
    point's 2D track) with the unnumbered pieces of track numbered (module docstring), and
    how many points got a number.

    Args:
        frames: every frame of the pass.
        track_ids: per frame, (k,) the track of each point.
        cameras: ``{name: camera}`` of the two cameras.
        grid_uv: camera -> marker -> (2,) px, the fitted grid (the markers' places at the
            pass's start).
        diameter_px: camera -> a marker's diameter in its images [px].
        epipolar_px: the pipeline's ``epipolar_px``: a pair's line distance gate [px].
        fps: the frame rate [1/s].
    """
    out, given = list(frames), 0
    if not out:
        return out, 0
    grid = {m for g in grid_uv.values() for m in g}
    for _ in range(ROUNDS):
        out, n = number_round(out, track_ids, cameras, grid_uv, epipolar_px, fps, grid,
                              diameter_px)
        given += n
        if not n:
            break
    return out, given
