"""Numbering from the whole pass, jointly: tracks no frame-by-frame rule numbered, decided at
the end of the pass by one optimal assignment over all their frames.

The frame-by-frame rules decide at one instant, where two markers can lie on one epipolar line
or near one grid point, so they leave such a track unnumbered from its first frame to its last.
Over a pass two markers rarely stay on one line: a track that stayed within a pixel of the line
of one marker the other camera gave out, in every frame they share, while every other candidate
strayed, is that marker. With the whole pass held (``StereoTrackConfig.number_delay_frames`` at
least the pass's frames), :func:`number_whole_pass` takes the frames as they would be given out
and numbers in two steps:

1. **One camera's tracks by the other camera's numbers.** Each track a camera never numbered is
   scored against every marker that camera does not give out at the track's frames, by the
   other camera's point of that marker (interpolated to the track's stamps): the mean and the
   largest distance from the epipolar line over the frames they share
   (:func:`pair_cost`). The other camera's never-numbered tracks are rivals (the track may be a
   marker the other camera sees but never numbered). One assignment per camera
   (``scipy.optimize.linear_sum_assignment``) on the mean distances; a track takes its marker
   only when the second-best candidate of its row and of its column is clearly worse
   (:func:`clear_winner`), and the pair's 3D points continue the marker's own numbered 3D
   points before and after (:func:`continues`): a marker cannot jump.
2. **Tracks neither camera numbered.** The two cameras' never-numbered tracks are paired by one
   assignment on the same cost into 3D tracklets (with the same margin); each tracklet takes
   the marker neither camera gives out at its frames whose own numbered 3D points (or, never
   numbered, its grid point at the start) it continues best, with the same margin.

Numbers go only to the frames where the pair was checked on the line (the other camera's point
within ``WORST_SHARE * epipolar_px`` of it, and a 3D point that continues the marker's), and
never to a frame that gives the number out already: withholding is better than a switch.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from itertools import pairwise
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import triangulate_pairs
from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.trajectories import (
    interpolate_history,
    marker_histories,
    paired_points,
)

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
MIN_SHARED = 3  # frames a track and a candidate must share to be scored (fewer: a chance)
JUMP_PX = 10.0  # a track is cut where a link missed its constant-velocity prediction by more
# than this [px] (pair_checks.JUMP_SHARE x doubt_link_px: such a link waits for the other camera)
MEDIAN_SHARE = 0.5  # largest median distance from the line over the shared frames, x epipolar_px
WORST_SHARE = 1.0  # largest distance in any shared frame, x epipolar_px (the live check's)
GIVE_SHARE = 0.5  # a frame takes the number only this near its line, x epipolar_px (a frame
# farther, within WORST_SHARE, may hold the spot of a neighbour the track ran into)
MARGIN_RATIO = 3.0  # the second-best candidate's mean distance must be this many times ...
MARGIN_PX = 1.0  # ... the best's plus this [px] (else two candidates fit: refuse)
MARGIN_SHARE = 2.0  # by continuity: the second-nearest marker's share that many times the best
CONTINUE_M = 0.015  # a piece's end may lie this far from the marker's extrapolated 3D point [m]
CONTINUE_SPEED_M_S = 0.5  # ... plus this times the time between them [m/s] (sand moves smoothly)
CONTINUE_PX = 6.0  # a piece's end may lie this far from the marker's extrapolated point [px]
CONTINUE_PX_FRAME = 8.0  # ... plus this per frame between them [px]
START_FRAMES = 2  # a piece of a marker nothing else places must start within this many frames
GRID_GATE_PX = 12.0  # ... this near its fitted grid point [px] (the grid fit's gate)


class Track(NamedTuple):
    """One camera's never-numbered track over the pass.

    Attributes:
        camera: its camera.
        track_id: the linker's id.
        piece: which piece of that track (:func:`smooth_pieces`).
        times: (k,) its points' stamps [s], increasing.
        uv: (k, 2) its points [px].
        where: (k, 2) each point's frame (index into the frames) and place in that frame.
    """

    camera: str
    track_id: int
    piece: int
    times: FloatArray
    uv: FloatArray
    where: NDArray[np.int64]


class PairFit(NamedTuple):
    """A track against a candidate of the other camera over their shared frames.

    Attributes:
        shared: (k,) which of the track's points the candidate has at that instant.
        checked: (k,) which shared points lie within ``GIVE_SHARE * epipolar_px`` of their
            line (the points that may take the number).
        median_px: median distance from the epipolar line over the shared points [px] (how
            well the candidate fits, whether or not it may be given: the rivals' score).
        fits: whether the candidate may be given: the median within ``MEDIAN_SHARE`` and
            every shared point within ``WORST_SHARE`` times ``epipolar_px``.
        xyz: (k, 3) the pair's 3D points [m] (NaN where not shared).
    """

    shared: NDArray[np.bool_]
    checked: NDArray[np.bool_]
    median_px: float
    fits: bool
    xyz: FloatArray


class Assignment(NamedTuple):
    """A whole-pass number: the marker, the tracks (one or two cameras), the points of each
    that take it, and the step that gave it (``pair``, ``tracklet``, ``own_path``)."""

    marker: int
    tracks: tuple[Track, ...]
    shared: tuple[NDArray[np.bool_], ...]
    step: str


def never_numbered(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                   camera: str, fps: float) -> list[Track]:
    """``camera``'s tracks that no frame gives out numbered, cut where they jump or come back
    after a gap (:func:`smooth_pieces`), the pieces of at least ``MIN_SHARED`` points (by id,
    then time) but those that begin with a re-attachment after a gap (a lost track re-attached
    may be on a neighbour's or a partly covered marker's off-centre spot: on `t113_asis` such a
    piece paired with the other camera's 12 to 0.1-0.6 px and was 4 switches and 3 wrong
    pairs)."""
    rows: dict[int, list[tuple[float, float, float, int, int]]] = {}
    numbered: set[int] = set()
    for i, (f, ids) in enumerate(zip(frames, track_ids, strict=True)):
        if f.camera != camera:
            continue
        for k, (m, tid) in enumerate(zip(f.markers.tolist(), ids.tolist(), strict=True)):
            if m >= 0:
                numbered.add(tid)
            else:
                u, v = (float(x) for x in f.uv[k])
                rows.setdefault(tid, []).append((f.stamp_s, u, v, i, k))
    out = []
    for tid, rs in sorted(rows.items()):
        if tid in numbered:
            continue
        times, uv = np.array([r[0] for r in rs]), np.array([r[1:3] for r in rs])
        where = np.array([r[3:] for r in rs], np.int64)
        out += [Track(camera, tid, n, times[p], uv[p], where[p])
                for n, p in enumerate(smooth_pieces(times, uv, fps)) if len(p) >= MIN_SHARED
                and not (p[0] > 0 and times[p[0]] - times[p[0] - 1] > 1.5 / fps)]
    return out


def smooth_pieces(times: FloatArray, uv: FloatArray, fps: float) -> list[NDArray[np.int64]]:
    """The indices of a track's pieces (times (k,) s, uv (k, 2) px): cut after a gap of more
    than 1.5 frame periods (a re-attachment) and where a point lies more than ``JUMP_PX`` from
    where its two predecessors in the piece carried it (constant velocity over their time
    steps): a link that jumped, often onto a neighbour (a marker cannot jump)."""
    cuts = [0]
    t, u, v = times.tolist(), uv[:, 0].tolist(), uv[:, 1].tolist()  # floats: a loop per point
    for k in range(1, len(t)):
        if t[k] - t[k - 1] > 1.5 / fps:
            cuts.append(k)
            continue
        if k - cuts[-1] < 2:
            continue
        dt = t[k - 1] - t[k - 2]
        ahead = t[k] - t[k - 1]
        du = u[k] - (u[k - 1] + (u[k - 1] - u[k - 2]) / dt * ahead)
        dv = v[k] - (v[k - 1] + (v[k - 1] - v[k - 2]) / dt * ahead)
        if math.sqrt(du * du + dv * dv) > JUMP_PX:
            cuts.append(k)
    cuts.append(len(times))
    return [np.arange(a, b) for a, b in pairwise(cuts)]


def pair_cost(cam: Camera, other_cam: Camera, track: Track, other_uv: FloatArray,
              epipolar_px: float) -> PairFit | None:
    """``track`` against the other camera's points ``other_uv`` (k, 2) px at its stamps (NaN:
    none); None when they share fewer than ``MIN_SHARED`` points."""
    shared: NDArray[np.bool_] = np.asarray(np.isfinite(other_uv).all(axis=1), bool)
    if shared.sum() < MIN_SHARED:
        return None
    xyz_s, epi = triangulate_pairs(cam, other_cam, track.uv[shared], other_uv[shared])
    median = float(np.median(epi))
    fits = bool(epi.max() <= WORST_SHARE * epipolar_px and median <= MEDIAN_SHARE * epipolar_px)
    xyz = np.full((len(shared), 3), np.nan)
    xyz[shared] = xyz_s
    checked = shared.copy()
    checked[shared] = epi <= GIVE_SHARE * epipolar_px
    return PairFit(shared, checked, median, fits, xyz)


def clear_winner(cost: FloatArray, allowed: NDArray[np.bool_], row: int, col: int,
                 ratio: float, margin: float) -> bool:
    """Whether ``cost[row, col]`` (finite) is clearly below (``ratio`` times plus ``margin``)
    every other score of its row (its track's other candidates, allowed or not: a candidate
    that fits most frames but not all may still be what the track is) and every other
    allowed score of its column (the candidate's other tracks that fit it in every frame:
    one that strays is not it). One optimal assignment can pick a pair by a hair, and a
    close second means the pass cannot tell the two apart."""
    best = cost[row, col]
    column = np.delete(np.where(allowed[:, col], cost[:, col], np.inf), row)
    others = np.concatenate([np.delete(cost[row], col), column])
    others = others[np.isfinite(others)]
    return not len(others) or bool(others.min() >= ratio * best + margin)


def assign(cost: FloatArray, ratio: float, margin: float,
           allowed: NDArray[np.bool_] | None = None) -> list[tuple[int, int]]:
    """The (row, column) pairs of the optimal assignment of the ``allowed`` pairs (None: every
    finite one) on ``cost`` (inf: no score) that are clear winners (:func:`clear_winner`)
    against every scored rival, allowed or not (a rival only scored takes no column from the
    assignment: it can only refuse)."""
    from scipy.optimize import linear_sum_assignment

    allowed = np.isfinite(cost) if allowed is None else allowed & np.isfinite(cost)
    if not cost.size or not allowed.any():
        return []
    big = 1e6 + float(cost[allowed].max())
    rows, cols = linear_sum_assignment(np.where(allowed, cost, big))
    return [(int(r), int(c)) for r, c in zip(rows, cols, strict=True)
            if allowed[r, c] and clear_winner(cost, allowed, int(r), int(c), ratio, margin)]


def marker_points_3d(frames: Sequence[PixelFrame], cameras: dict[str, Camera], fps: float,
                     ) -> dict[int, tuple[FloatArray, FloatArray]]:
    """``{marker: (times (k,) s, xyz (k, 3) m)}``: every numbered pair given out (each of one
    camera's numbered points with the other camera's point of that number interpolated to its
    stamp), in time order."""
    names = sorted(cameras)
    hist = {c: marker_histories(list(frames), c) for c in names}
    out: dict[int, tuple[FloatArray, FloatArray]] = {}
    for m in sorted(set(hist[names[0]]) & set(hist[names[1]])):
        times, xyz, _ = paired_points(hist[names[0]][m], hist[names[1]][m], cameras[names[0]],
                                      cameras[names[1]], fps)
        if len(times):
            out[m] = (times, xyz)
    return out


def end_gaps(times: FloatArray, points: FloatArray, own: tuple[FloatArray, FloatArray],
             ) -> list[tuple[float, float]] | None:
    """``[(distance, time between [s]), ...]`` of a piece's first point (times (k,) s, points
    (k, d)) from where the marker's own points ``own`` (times, (n, d)) last before it carry it
    (its last point moved on at its last velocity), and of its last point from the marker's
    first own point after it (carried back likewise); None when the marker has own points
    within the piece's time (it cannot be both)."""
    t_own, p_own = own
    if np.any((t_own >= times[0]) & (t_own <= times[-1])):
        return None
    out = []
    for side in ('before', 'after'):
        idx = np.flatnonzero(t_own < times[0] if side == 'before' else t_own > times[-1])
        if not len(idx):
            continue
        j, t0, p0 = (idx[-1], times[0], points[0]) if side == 'before' else \
            (idx[0], times[-1], points[-1])
        near = idx[-2] if side == 'before' and len(idx) > 1 else \
            (idx[1] if side == 'after' and len(idx) > 1 else None)
        velocity = 0 if near is None else (p_own[j] - p_own[near]) / (t_own[j] - t_own[near])
        dt = abs(t0 - t_own[j])
        out.append((float(np.linalg.norm(p0 - (p_own[j] + velocity * (t0 - t_own[j])))), dt))
    return out


def continuity(pieces: dict[str, tuple[FloatArray, FloatArray]], xyz: tuple[FloatArray,
               FloatArray] | None, marker: int, own_2d: dict[str, dict[int, tuple[FloatArray,
               FloatArray]]], own_3d: dict[int, tuple[FloatArray, FloatArray]],
               grid_uv: dict[str, dict[int, FloatArray]], start_s: float, fps: float) -> float:
    """How far a piece of track lies from ``marker``'s own path, as a share of what a marker
    can move (<= 1: it may be that marker; inf: it cannot, or nothing says).

    Each camera's piece (``pieces``: camera -> (times (k,) s, (k, 2) px)) against that
    camera's own numbered points of the marker before and after it (``own_2d``: within
    ``CONTINUE_PX`` plus ``CONTINUE_PX_FRAME`` per frame between), the piece's 3D points
    (``xyz``: (times, (k, 3) m), a pair) against the marker's own 3D points (``own_3d``: within
    ``CONTINUE_M`` plus ``CONTINUE_SPEED_M_S`` times the time between); with none of these, a
    piece that starts within ``START_FRAMES`` frames of the pass (``start_s``) against the
    marker's fitted grid point in that camera (``grid_uv``: within ``GRID_GATE_PX``). The
    largest share over the checks; a marker cannot jump."""
    shares: list[float] = []
    for cam, (times, uv) in pieces.items():
        own = own_2d.get(cam, {}).get(marker)
        gaps = None if own is None else end_gaps(times, uv, own)
        if gaps is None and own is not None:
            return np.inf
        shares += [d / (CONTINUE_PX + CONTINUE_PX_FRAME * dt * fps) for d, dt in gaps or []]
    if xyz is not None and marker in own_3d and len(xyz[0]):
        gaps = end_gaps(*xyz, own_3d[marker])
        if gaps is None:
            return np.inf
        shares += [d / (CONTINUE_M + CONTINUE_SPEED_M_S * dt) for d, dt in gaps]
    if not shares:
        for cam, (times, uv) in pieces.items():
            at = grid_uv.get(cam, {}).get(marker)
            if at is not None and times[0] - start_s <= (START_FRAMES + 0.5) / fps:
                shares.append(float(np.linalg.norm(uv[0] - at)) / GRID_GATE_PX)
    return max(shares) if shares else np.inf


def lacks(hist: dict[int, tuple[FloatArray, FloatArray]], marker: int, times: FloatArray,
          fps: float) -> bool:
    """Whether a camera's numbered points ``hist`` have ``marker`` at none of ``times`` [s]
    (within half a frame period)."""
    own = hist.get(marker)
    if own is None or not len(times):
        return True
    gap = np.abs(own[0][None, :] - times[:, None]).min(axis=1)
    return bool(np.all(gap > 0.5 / fps))


def along(track: Track, times: FloatArray, fps: float) -> FloatArray:
    """(len(times), 2) px: ``track`` interpolated to ``times`` (NaN outside it or over gaps
    of more than 1.5 frame periods)."""
    return interpolate_history((track.times, track.uv), times, 1.5 / fps)


class Pass(NamedTuple):
    """What the steps read of the pass.

    Attributes:
        cameras: ``{name: camera}``.
        own_2d: camera -> marker -> (times (k,) s, (k, 2) px): its numbered points.
        own_3d: marker -> (times (k,) s, (k, 3) m): its numbered pairs' 3D points.
        grid_uv: camera -> marker -> (2,) px: the fitted grid.
        start_s: the pass's first stamp [s].
        epipolar_px: the pipeline's ``epipolar_px``.
        fps: the frame rate [1/s].
    """

    cameras: dict[str, Camera]
    own_2d: dict[str, dict[int, tuple[FloatArray, FloatArray]]]
    own_3d: dict[int, tuple[FloatArray, FloatArray]]
    grid_uv: dict[str, dict[int, FloatArray]]
    start_s: float
    epipolar_px: float
    fps: float

    def other(self, camera: str) -> str:
        """The other camera's name."""
        return next(c for c in self.cameras if c != camera)

    def fit(self, track: Track, other_uv: FloatArray) -> PairFit | None:
        """:func:`pair_cost` of ``track`` against the other camera's points."""
        return pair_cost(self.cameras[track.camera], self.cameras[self.other(track.camera)],
                         track, other_uv, self.epipolar_px)

    def share(self, pieces: dict[str, tuple[FloatArray, FloatArray]],
              xyz: tuple[FloatArray, FloatArray] | None, marker: int) -> float:
        """:func:`continuity` of the pieces with ``marker``."""
        return continuity(pieces, xyz, marker, self.own_2d, self.own_3d, self.grid_uv,
                          self.start_s, self.fps)


def by_other_numbers(ps: Pass, camera: str, tracks: list[Track], rivals: list[Track],
                     ) -> list[Assignment]:
    """Step 1: ``camera``'s never-numbered ``tracks`` numbered by the other camera's points of
    the markers ``camera`` lacks at their frames (whose own path the pair does not leave:
    :func:`continuity`), the other camera's never-numbered tracks (``rivals``) competing as
    columns of the same assignment."""
    own, theirs = ps.own_2d[camera], ps.own_2d[ps.other(camera)]
    markers = sorted(theirs)
    cost = np.full((len(tracks), len(markers) + len(rivals)), np.inf)
    allowed = np.zeros(cost.shape, bool)
    fits: dict[tuple[int, int], PairFit] = {}
    for i, t in enumerate(tracks):
        for j, m in enumerate(markers):
            if not lacks(own, m, t.times, ps.fps):
                continue
            fit = ps.fit(t, interpolate_history(theirs[m], t.times, 1.5 / ps.fps))
            if fit is None:
                continue
            ok = fit.checked
            share = ps.share({camera: (t.times, t.uv)}, (t.times[ok], fit.xyz[ok]), m)
            if share <= 1 or (np.isinf(share) and not contradicts(ps, camera, t, m)):
                cost[i, j], fits[i, j], allowed[i, j] = fit.median_px, fit, fit.fits
        for j, r in enumerate(rivals, start=len(markers)):
            fit = ps.fit(t, along(r, t.times, ps.fps))
            if fit is not None:
                cost[i, j] = fit.median_px
    return [Assignment(markers[j], (tracks[i],), (fits[i, j].checked,), 'pair')
            for i, j in assign(cost, MARGIN_RATIO, MARGIN_PX, allowed) if j < len(markers)]


def contradicts(ps: Pass, camera: str, track: Track, marker: int) -> bool:
    """Whether the marker's own points in ``camera`` or in 3D overlap the track's time (it
    cannot be both): the one way :func:`continuity` says inf with something to say."""
    spans = [ps.own_2d[camera].get(marker), ps.own_3d.get(marker)]
    return any(s is not None and np.any((s[0] >= track.times[0]) & (s[0] <= track.times[-1]))
               for s in spans)


Tracklet = tuple[tuple[Track, Track], tuple[NDArray[np.bool_], NDArray[np.bool_]], PairFit]


def pair_tracklets(ps: Pass, tracks: dict[str, list[Track]]) -> list[Tracklet]:
    """The two cameras' ``tracks`` paired into 3D tracklets by one assignment on the median
    epipolar distance (:func:`pair_cost`, the other track interpolated to each stamp), with
    its margin, kept when the pair fits both ways: ``((track a, track b), (the points of each
    that may take a number), a's fit against b)``, the cameras in name order."""
    a, b = sorted(ps.cameras)
    cost = np.full((len(tracks[a]), len(tracks[b])), np.inf)
    allowed = np.zeros(cost.shape, bool)
    fits: dict[tuple[int, int], PairFit] = {}
    for i, t in enumerate(tracks[a]):
        for j, u in enumerate(tracks[b]):
            if t.times[-1] < u.times[0] or u.times[-1] < t.times[0]:
                continue  # no common stretch (pair_cost: no score)
            fit = ps.fit(t, along(u, t.times, ps.fps))
            if fit is not None:
                cost[i, j], fits[i, j], allowed[i, j] = fit.median_px, fit, fit.fits
    out = []
    for i, j in assign(cost, MARGIN_RATIO, MARGIN_PX, allowed):
        t, u = tracks[a][i], tracks[b][j]
        back = ps.fit(u, along(t, u.times, ps.fps))
        if back is not None and back.fits:
            out.append(((t, u), (fits[i, j].checked, back.checked), fits[i, j]))
    return out


def by_continuity(ps: Pass, tracks: dict[str, list[Track]],
                  rivals: dict[str, list[Track]]) -> list[Assignment]:
    """Step 2: the two cameras' never-numbered tracks paired into 3D tracklets (one
    assignment on the epipolar cost, with its margin), each numbered by the marker neither
    camera gives out at its frames whose own path it continues (:func:`continuity`), by one
    assignment on that share with ``MARGIN_SHARE``."""
    a, b = sorted(ps.cameras)
    tracklets = pair_tracklets(ps, tracks)
    markers = sorted(set(range(1, 1 + max((len(g) for g in ps.grid_uv.values()), default=0)))
                     | set(ps.own_3d) | {m for h in ps.own_2d.values() for m in h})
    cost = np.full((len(tracklets), len(markers)), np.inf)
    for i, ((t, u), (ct, _), fit) in enumerate(tracklets):
        pieces = {a: (t.times, t.uv), b: (u.times, u.uv)}
        for j, m in enumerate(markers):
            if lacks(ps.own_2d[a], m, t.times, ps.fps) and lacks(ps.own_2d[b], m, u.times,
                                                                   ps.fps):
                cost[i, j] = ps.share(pieces, (t.times[ct], fit.xyz[ct]), m)
    cost[cost > 1] = np.inf
    return [Assignment(markers[j], *tracklets[i][:2], 'tracklet')
            for i, j in assign(cost, MARGIN_SHARE, 0.0)]


def number_whole_pass(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                      cameras: dict[str, Camera], grid_uv: dict[str, dict[int, FloatArray]],
                      epipolar_px: float, fps: float) -> tuple[list[PixelFrame], int]:
    """The pass's frames (both cameras, in order, as they would be given out; ``track_ids``
    (k,) each point's track) with the never-numbered tracks numbered by the steps of the
    module in turn (each step sees the numbers the steps before it gave), and how many points
    got a number.

    Args:
        frames: every frame of the pass.
        track_ids: per frame, (k,) the track of each point.
        cameras: ``{name: camera}`` of the two cameras.
        grid_uv: camera -> marker -> (2,) px, the fitted grid.
        epipolar_px: the pipeline's ``epipolar_px``.
        fps: the frame rate [1/s].
    """
    names = sorted(cameras)
    out, given = list(frames), 0
    start = min(f.stamp_s for f in frames)
    for step in STEPS:
        ps = Pass(cameras, {c: marker_histories(out, c) for c in names},
                  marker_points_3d(out, cameras, fps), grid_uv, start, epipolar_px, fps)
        tracks = {c: never_numbered(out, track_ids, c, fps) for c in names}
        out, n = give(out, step(ps, tracks, tracks))
        given += n
    return out, given


def by_other_numbers_both(ps: Pass, tracks: dict[str, list[Track]],
                          rivals: dict[str, list[Track]]) -> list[Assignment]:
    """Step 1 for the first camera's tracks (the second camera's come next, seeing these)."""
    first = sorted(tracks)[0]
    return by_other_numbers(ps, first, tracks[first], rivals[ps.other(first)])


def by_other_numbers_second(ps: Pass, tracks: dict[str, list[Track]],
                            rivals: dict[str, list[Track]]) -> list[Assignment]:
    """Step 1 for the second camera's tracks."""
    second = sorted(tracks)[1]
    return by_other_numbers(ps, second, tracks[second], rivals[ps.other(second)])


STEPS = (by_other_numbers_both, by_other_numbers_second, by_continuity)


def give(frames: Sequence[PixelFrame], found: list[Assignment]) -> tuple[list[PixelFrame], int]:
    """``frames`` with each assignment's marker given to its tracks' checked points, except in
    a frame that gives that number out already; and how many points got it."""
    markers = [f.markers.copy() for f in frames]
    given = 0
    for a in found:
        for track, shared in zip(a.tracks, a.shared, strict=True):
            for i, k in track.where[shared].tolist():
                if a.marker not in markers[i]:
                    markers[i][k] = a.marker
                    given += 1
        LOG.info('whole pass (%s): %s numbered %d', a.step, '+'.join(
            f'{t.camera} track {t.track_id}' for t in a.tracks), a.marker)
    return [f._replace(markers=m) for f, m in zip(frames, markers, strict=True)], given
