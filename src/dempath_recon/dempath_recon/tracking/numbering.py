"""The two-camera tracker's numbering of one camera's tracks: all at once by the marker grid
(a camera's first frame that fits it), then each new track by the other camera's epipolar lines
at a depth the marker can have reached, or, for a marker this camera never saw, by its fitted
grid point.

Functions on :class:`~dempath_recon.tracking.state.StereoState`; a number given here is taken
back if a later pair contradicts it (:func:`~dempath_recon.tracking.pair_checks.verify`).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import (
    epipolar_distance,
    number_by_grid,
    on_epipolar_line,
    triangulate_pairs,
)
from dempath_recon.tracking.grid_pairs import GATE_SHARE, grid_pitch, pairs_by_grid
from dempath_recon.tracking.half_ghost import drop_half_ghosts
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.one_camera import grid_anchor, late_grid, lost_nearby
from dempath_recon.tracking.pair_anchor import (
    drop_contested,
    drop_unclaimed_nearer,
    pair_shift,
    vote_contradicted,
)
from dempath_recon.tracking.ray_rivals import hold_rivals
from dempath_recon.tracking.state import (
    MAX_DEPTH_AGE_S,
    RECENT_S,
    StereoState,
    at_stamp,
    retire,
    sure_numbers,
)

FloatArray = NDArray[np.float64]


def number_all_by_grid(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                       uv: FloatArray, stamp_s: float, events: list[str]) -> NDArray[np.int32]:
    """Number the tracks by the grid: both cameras' at once from pairs matched to the grid in
    3D (:func:`~dempath_recon.tracking.grid_pairs.number_pairs_by_grid`) when the other camera's
    last frame is at most 1.5 frame periods old and not numbered by the grid yet, or numbered
    only provisionally (alone, before this camera's first frame: its numbers are replaced).
    Failing that (too few pairs fit the grid, or no frame of the other camera), this camera
    alone by the projected grid, once enough detections fit it and no fit one pitch over
    fits nearly as well (``wary``: on a tuning render the front, with 4 of its 10 markers
    found, fitted one column over while the side was numbered and kept 13 for 12 and 12 for
    11, 19 wrong marker-frames), provisionally while the other camera has sent no frame."""
    need = min(state.config.min_grid_markers, len(state.config.grid.points()[0]))
    other = state.other(camera)
    if other not in state.grid_uv or other in state.provisional:
        joint = number_both_by_grid(state, camera, track_ids, uv, stamp_s, need, events)
        if joint is not None:
            return joint
    if state.last_stamp[other] is None:
        state.provisional.add(camera)
    numbers, grid_uv = number_by_grid(state.cameras[camera], uv, state.config.grid,
                                      state.config.grid_gate_px, wary=True)
    found = int((numbers >= 0).sum())
    if found < need:
        events.append(f'{camera}: {found} of {len(uv)} detections fit the marker grid; '
                      f'numbering waits for {need}')
        return np.full(len(uv), UNNUMBERED, np.int32)
    for tid, m in zip(track_ids, numbers, strict=True):
        if m >= 0:
            state.trackers[camera].number(int(tid), int(m))
    state.grid_uv[camera] = dict(zip(state.config.grid.points()[0].tolist(), grid_uv,
                                     strict=True))
    state.grid_time[camera] = state.last_stamp[camera] or 0.0
    events.append(f'{camera}: {found} of {len(uv)} detections numbered by the grid')
    return numbers


def number_both_by_grid(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                        uv: FloatArray, stamp_s: float, need: int, events: list[str],
                        ) -> NDArray[np.int32] | None:
    """Both cameras' tracks numbered together (this frame's and the other camera's last
    frame's unnumbered ones), when at least ``need`` markers pair up on the grid; None
    otherwise. The other camera's numbered points become its latest, so the pair checks of
    this frame check them and record the markers' 3D positions. A merged spot (one camera sees
    two markers along one line of sight, :func:`~dempath_recon.tracking.grid_pairs.pairs_by_grid`)
    is refused both numbers for its track: later numbering by the epipolar line would pick
    between them by grid points the markers have left (on three tuning renders it gave a
    front spot of 12 the number 13, 14 frames each). A pair whose number the provisional
    camera's own grid gave its spot differently is not given (a ghost pair:
    :func:`~dempath_recon.tracking.pair_anchor.drop_contested`)."""
    other = state.other(camera)
    last = state.last_tracks[other]
    if last is None or abs(last[0] - stamp_s) > 1.5 / state.config.fps or not len(last[1]):
        return None
    t_o, ids_o, uv_o = last
    if other not in state.provisional:  # only its unnumbered tracks are free
        numbered = {t.track_id for t in state.trackers[other].tracks if t.marker >= 0}
        keep = np.array([int(t) not in numbered for t in ids_o], bool)
        ids_o, uv_o = ids_o[keep], uv_o[keep]
    fit = pairs_by_grid(state.cameras[camera], state.cameras[other], uv, uv_o,
                        state.config.grid, state.config.epipolar_px)
    mine, theirs = fit.a, fit.b
    found = int((mine >= 0).sum())
    if found < need:
        return None
    for cam, ids, nums, merged in ((camera, track_ids, mine, fit.merged_a),
                                   (other, ids_o, theirs, fit.merged_b)):
        state.refused[cam] |= {(int(ids[i]), m) for i, ms in merged.items() for m in ms
                               if m != nums[i]}
        state.fit_merged[cam] = {int(ids[i]): {m for m in ms if m != nums[i]}
                                 for i, ms in merged.items()}
    if other in state.provisional:  # the numbers it gave out alone check the pairs
        own = {t.track_id: t.marker for t in state.trackers[other].tracks}
        mine, theirs = drop_contested(mine, theirs, np.array(
            [own.get(int(t), UNNUMBERED) for t in ids_o], np.int32), camera, other, events)
    near, near_o = grid_rival(state, camera, uv, mine), grid_rival(state, other, uv_o, theirs)
    kept, kept_o = drop_unclaimed_nearer(mine, theirs, near, near_o, camera, events)
    if state.config.half_ghost:
        kept, kept_o = drop_half_ghosts(
            kept, kept_o, near, near_o,
            epipolar_distance(state.cameras[camera], state.cameras[other], uv, uv_o),
            state.config.epipolar_px, camera, other, events)
    for cam, ids, nums, left in ((camera, track_ids, mine, kept), (other, ids_o, theirs, kept_o)):
        state.refused[cam] |= {(int(ids[i]), int(nums[i]))  # a ghost's spots are not its number
                               for i in np.flatnonzero((nums >= 0) & (left < 0)).tolist()}
    mine, theirs = kept, kept_o
    alone, unsure = one_camera_grid(state, camera, uv, mine, uv_o, theirs, fit.shift)
    alone_o, unsure_o = one_camera_grid(state, other, uv_o, theirs, uv, mine, fit.shift)
    if state.config.ray_rivals:  # a number a camera's own image grid gave (no pair) waits
        # while other markers rest near its line of sight
        alone = hold_rivals(state, camera, track_ids, uv, alone, (alone >= 0) & (mine < 0),
                            uv_o, alone_o, fit.shift, events)
        alone_o = hold_rivals(state, other, ids_o, uv_o, alone_o,
                              (alone_o >= 0) & (theirs < 0), uv, alone, fit.shift, events)
    mine, theirs = alone, alone_o
    for cam, ids, waits in ((camera, track_ids, unsure), (other, ids_o, unsure_o)):
        state.grid_unsure[cam] = {int(t): int(m) for t, m in zip(ids, waits, strict=True)
                                  if m >= 0}
    if other in state.provisional:  # its own grid's numbers give way to the pairs'
        for tid in ids_o.tolist():
            state.trackers[other].number(int(tid), UNNUMBERED)
        state.latest[other].clear()
        state.provisional.discard(other)
    for cam, ids, nums, pts in ((camera, track_ids, mine, uv), (other, ids_o, theirs, uv_o)):
        for tid, m in zip(ids, nums, strict=True):
            if m >= 0:
                state.trackers[cam].number(int(tid), int(m))
        voted, grid_uv = number_by_grid(state.cameras[cam], pts, state.config.grid,
                                        state.config.grid_gate_px)
        if vote_contradicted(voted, nums):  # the fitted grid points where the pairs put them
            grid_uv = number_by_grid(state.cameras[cam], pts, state.config.grid,
                                     state.config.grid_gate_px, shift_px=pair_shift(
                                         state.cameras[cam], pts, nums, state.config.grid))[1]
        state.grid_uv[cam] = dict(zip(state.config.grid.points()[0].tolist(), grid_uv,
                                      strict=True))
    for m, p in zip(theirs, uv_o, strict=True):
        if m >= 0:
            state.latest[other][int(m)] = (t_o, p)
    state.grid_time[camera], state.grid_time[other] = stamp_s, t_o
    events.append(f"{camera}: {found} of {len(uv)} detections numbered with {other}'s "
                  'by the grid in 3D')
    return mine


def grid_rival(state: StereoState, camera: str, uv: FloatArray, numbers: NDArray[np.int32],
               ) -> NDArray[np.int32]:
    """(n,) for each of ``camera``'s spots ``uv`` (n, 2) px numbered ``numbers`` (n,) by the
    pairs, the other marker whose grid point, as this camera's own grid vote fits it, lies
    nearest the spot, when the spot's own grid point lies at least ``GHOST_RATIO`` times as far
    (-1 otherwise, for unnumbered spots, and for all when the pairs contradict the vote: it
    slipped a pitch and its grid points say nothing)."""
    out = np.full(len(uv), UNNUMBERED, np.int32)
    voted, grid_uv = number_by_grid(state.cameras[camera], uv, state.config.grid,
                                    state.config.grid_gate_px)
    if not len(uv) or vote_contradicted(voted, numbers):
        return out
    ids = state.config.grid.points()[0].tolist()
    d = np.linalg.norm(uv[:, None] - np.asarray(grid_uv)[None], axis=2)
    for i in np.flatnonzero(numbers >= 0).tolist():
        own = d[i, ids.index(int(numbers[i]))]
        j = int(np.argmin(d[i]))
        if ids[j] != numbers[i] and own >= GHOST_RATIO * d[i, j]:
            out[i] = ids[j]
    return out


def one_camera_grid(state: StereoState, camera: str, uv: FloatArray, numbers: NDArray[np.int32],
                    uv_o: FloatArray, numbers_o: NDArray[np.int32], shift: FloatArray,
                    ) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    """``numbers`` (the pairs' numbers of ``camera``'s detections ``uv``) with the markers only
    this camera sees numbered by its projected grid: a detection the pairs left unnumbered
    takes its grid number when no pair took that number and no unnumbered detection of the
    other camera (``uv_o``, ``numbers_o``) lies on its epipolar line (such a pair was left
    unnumbered as unsure) and the other camera's numbered ones do not say otherwise
    (:func:`other_says_else`, with the pairs' 3D points against the grid shifted by the fit's
    ``shift`` (3,) m); and (k,) the grid number each such unsure detection would have
    taken (-1: none), which :func:`number_grid_unsure` may give it later."""
    single, _ = number_by_grid(state.cameras[camera], uv, state.config.grid,
                               state.config.grid_gate_px)
    if vote_contradicted(single, numbers):  # the pairs say the vote slipped: no grid numbers
        single = np.full(len(uv), UNNUMBERED, np.int32)
    cam, cam_o = state.cameras[camera], state.cameras[state.other(camera)]
    line = epipolar_distance(cam, cam_o, uv, uv_o) <= state.config.epipolar_px \
        if len(uv_o) and len(uv) else np.zeros((len(uv), len(uv_o)), bool)
    partnered = line[:, numbers_o < 0].any(axis=1)
    used = set(numbers[numbers >= 0].tolist())
    out = numbers.copy()
    ids, grid_xyz = state.config.grid.points()
    places = {int(m): x + shift for m, x in zip(ids.tolist(), grid_xyz, strict=True)}
    gate = GATE_SHARE * grid_pitch(state.config.grid)
    for i in np.flatnonzero((numbers < 0) & (single >= 0) & ~partnered).tolist():
        on = np.flatnonzero(line[i])
        xyz = triangulate_pairs(cam, cam_o, np.repeat(uv[i][None], len(on), axis=0),
                                uv_o[on])[0] if len(on) else np.zeros((0, 3))
        could = np.zeros(len(uv_o), bool)
        could[on] = [int(m) in places and float(np.linalg.norm(x - places[int(m)])) < gate
                     for m, x in zip(numbers_o[on].tolist(), xyz, strict=True)]
        if int(single[i]) not in used and not other_says_else(line[i], could, numbers_o,
                                                              int(single[i]), used):
            out[i] = single[i]
            used.add(int(single[i]))
    unsure = (out < 0) & (single >= 0) & partnered \
        & np.array([int(m) not in used for m in single], bool)
    return out, np.where(unsure, single, UNNUMBERED).astype(np.int32)


def other_says_else(line: NDArray[np.bool_], could: NDArray[np.bool_],
                    numbers_o: NDArray[np.int32], marker: int, used: set[int]) -> bool:
    """Whether the other camera's numbered detections contradict giving one detection
    ``marker`` by this camera's grid alone: ``line`` (k,) says which of the other camera's
    detections lie on the detection's epipolar line, ``could`` (k,) which of those pair with
    it at a 3D point within the grid fit's gate of their own number's grid point. The other
    camera's spot of ``marker`` off the line says it is elsewhere; a spot on the line
    numbered with a marker this camera has not placed, pairing at that marker's grid point,
    says the detection may be that one (a front spot of markers 9 and 10, one behind the
    other, sits on both of the side's lines and took 10 by the front's grid while it was
    9's). A numbered spot on the line whose pair lies far from its marker's grid point says
    nothing: the line of sight crosses that marker's at another depth (a front spot of
    marker 14, which the side did not see, lay on the line of the side's 9 while the front
    had 9 merged with 10, and stayed unnumbered all pass)."""
    if (numbers_o == marker).any() and not line[numbers_o == marker].any():
        return True
    on = numbers_o[line & could]
    return bool(((on >= 0) & (on != marker) & ~np.isin(on, list(used))).any())


@dataclass(frozen=True)
class LineCandidates:
    """The other camera's recent markers an unnumbered track of this camera may be, by the
    epipolar line (:func:`number_new`).

    Attributes:
        recent: marker -> (2,) px: the other camera's markers given out within ``RECENT_S``
            and not held here, moved to this frame's stamp along their tracks.
        lines: marker -> how many of this frame's unnumbered spots lie on its epipolar line.
        starts: track id -> the stamp each of this camera's tracks started [s].
    """

    recent: dict[int, FloatArray]
    lines: Counter[int]
    starts: dict[int, float]

    @classmethod
    def of(cls, state: StereoState, camera: str, uv: FloatArray, todo: NDArray[np.intp],
           held: set[int], stamp_s: float) -> LineCandidates:
        """The candidates of this frame's unnumbered spots ``todo`` (indices into ``uv`` (k,
        2) px), ``held`` the numbers this camera gives out now."""
        other = state.other(camera)
        recent = {m: at_stamp(state, other, m, (t, p), stamp_s)
                  for m, (t, p) in state.latest[other].items()
                  if m not in held and abs(t - stamp_s) <= RECENT_S}
        lines = Counter(m for k in todo for m in on_epipolar_line(
            state.cameras[camera], state.cameras[other], uv[k], recent,
            state.config.epipolar_px))
        return cls(recent, lines, {t.track_id: t.history[0][0]
                                   for t in state.trackers[camera].tracks})

    def for_track(self, state: StereoState, camera: str, track_id: int,
                  held: set[int]) -> dict[int, FloatArray]:
        """The markers track ``track_id`` may be: not held here (``held``), on no other
        unnumbered spot's line, not refused to it, and not seen by this camera since the
        track started (a track that ran beside marker m's own track is not m)."""
        start = self.starts.get(track_id, 0.0)
        return {m: p for m, p in self.recent.items()
                if m not in held and self.lines[m] == 1
                and (track_id, m) not in state.refused[camera]
                and state.latest[camera].get(m, (-np.inf, None))[0] < start}


def number_new(state: StereoState, camera: str, track_ids: NDArray[np.int64],
               markers: NDArray[np.int32], uv: FloatArray, stamp_s: float, events: list[str],
               ) -> NDArray[np.int32]:
    """Number unnumbered tracks from the other camera's recent markers, else by the grid.

    A candidate marker must not have been seen by this camera since the track started (a
    track that ran beside marker m's own track is not m), must lie on the track's epipolar
    line, and the pair's 3D point must be one the marker can have reached; the track is
    numbered only when exactly one candidate passes, and a candidate whose epipolar line
    passes more than one unnumbered detection of this frame is no candidate, nor is a marker
    never triangulated whose grid point lies much farther from the track than another
    unseen marker's (:func:`nearer_grid_point`). Failing that,
    a marker this camera has never seen that appears alone at its fitted grid point takes
    that number, unless the other camera sees that marker now (then its epipolar line
    decides, and it did not pass: on a tuning render a side track took marker 2's grid point
    while the front saw 2 elsewhere, and followed marker 1 for 6 frames). Numbers given here
    are taken back if a later pair contradicts them
    (:func:`~dempath_recon.tracking.pair_checks.verify`).
    """
    markers = markers.copy()
    seen = {int(m) for m in markers if m >= 0}
    todo = np.flatnonzero(markers == UNNUMBERED)
    lines = LineCandidates.of(state, camera, uv, todo, seen, stamp_s)
    for k in todo:
        tid = int(track_ids[k])
        cands = lines.for_track(state, camera, tid, seen)
        number = pick(state, camera, tid, uv[k], cands, stamp_s, events)
        if number < 0 and lines.starts.get(tid) == stamp_s \
                and tid not in state.ray_wait.get(camera, {}):  # a first frame, no rivals
            # a marker the other camera sees now is numbered only on its epipolar line
            number = late_grid(state, camera, uv, k, seen | set(lines.recent))
            rival = lost_nearby(state, camera, number, uv[k], sure_numbers(
                state, camera, track_ids, markers), stamp_s) if number >= 0 else None
            if rival is not None:
                events.append(f'{camera}: track {tid} is not numbered {number} at its grid '
                              f'point: marker {rival}, lost nearby, may be it')
                number = UNNUMBERED
            if number >= 0:
                state.counts[camera].numbered_by_grid_late += 1
                events.append(f'{camera}: track {tid} numbered marker {number}: it appeared '
                              'at its grid point, not seen by this camera before')
        if number < 0:
            state.counts[camera].unnumbered += 1
            continue
        retire(state, camera, number)
        state.trackers[camera].number(tid, number)
        state.late_numbered[camera].add(tid)
        markers[k] = number
        seen.add(number)
    return markers


def number_grid_unsure(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                       markers: NDArray[np.int32], uv: FloatArray, stamp_s: float,
                       events: list[str]) -> NDArray[np.int32]:
    """Resolve afterwards a track the grid numbering left unsure (``state.grid_unsure``: at the
    grid fit it sat at its grid point, but an unnumbered spot of the other camera lay on its
    epipolar line, a pair left unnumbered): it takes that grid number once no unnumbered spot
    of the other camera's latest frame (within a frame period) lies within ``epipolar_px`` of
    its line, if it kept its 2D links since the fit (never re-attached), is unnumbered and
    not refused that number, and neither camera has ever given that number out or holds it on
    a track. Such a number is taken back if a later pair contradicts it. (On a tuning render
    the front merged markers 9 and 10 into one spot at the fit; the side's clean spot of 10
    waited on that spot and was never numbered, 17 frames; once the front's spot was numbered
    9 nothing stood on its line.)"""
    waiting = state.grid_unsure.get(camera)
    other = state.other(camera)
    free_o = state.free[other]
    if not waiting or free_o is None or abs(free_o[0] - stamp_s) > 1.0 / state.config.fps:
        return markers
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    held = {t.marker for c in state.cameras for t in state.trackers[c].tracks}
    out = markers.copy()
    for k in np.flatnonzero(markers < 0).tolist():
        tid = int(track_ids[k])
        m = waiting.get(tid)
        track = tracks.get(tid)
        if m is None or track is None or track.marker >= 0 or track.reattached is not None \
                or (tid, m) in state.refused[camera] or m in held \
                or any(m in state.latest[c] for c in state.cameras):
            continue
        if len(free_o[2]) and (epipolar_distance(
                state.cameras[camera], state.cameras[other], uv[k][None], free_o[2])
                <= state.config.epipolar_px).any():
            continue
        del waiting[tid]
        state.trackers[camera].number(tid, m)
        state.late_numbered[camera].add(tid)
        state.counts[camera].numbered_by_grid_late += 1
        held.add(m)
        out[k] = m
        events.append(f'{camera}: track {tid} numbered marker {m}: at its grid point at the '
                      'fit, and the spot on its epipolar line then is numbered now')
    return out


GHOST_RATIO = 1.25  # a pair's spot is nearer another marker's grid point when its own is this
# many times as far (the fitted grid points sit 3-8 px from markers the bed has moved: a right
# pair of a seed-65 render sat 7.1 and 7.6 px from its own, 6.9 and 7.0 px from others'; a
# ghost pair of a seed-83 render 5.6 and 3.3 px from other markers', 7.8 and 8.2 px from its own)
GRID_RATIO = 2.0  # a spot is another marker's when that one's grid point is this many times
# nearer than the candidate's


def nearer_grid_point(state: StereoState, camera: str, marker: int, uv: FloatArray,
                      ) -> int | None:
    """A marker this camera has not seen whose fitted grid point in ``camera`` is
    ``GRID_RATIO`` times nearer the spot ``uv`` (2,) px than ``marker``'s, else None: a
    marker never triangulated is placed by its grid point, and a spot sitting on another
    unseen marker's grid point is that one's (on a tuning render the side's spot of marker
    10, 1 px from 10's grid point and 28 px from 14's, took 14 from the front's line)."""
    grid_uv = state.grid_uv.get(camera, {})
    if marker not in grid_uv:
        return None
    own = float(np.linalg.norm(uv - grid_uv[marker]))
    for m, p in sorted(grid_uv.items()):
        if m != marker and m not in state.latest[camera] \
                and GRID_RATIO * float(np.linalg.norm(uv - p)) < own:
            return int(m)
    return None


def pick(state: StereoState, camera: str, track_id: int, uv: FloatArray,
         candidates: dict[int, FloatArray], stamp_s: float, events: list[str]) -> int:
    """The one candidate on the track's epipolar line at a depth the marker can be at.

    Only markers with an accepted 3D position at most ``MAX_DEPTH_AGE_S`` old are
    candidates (a line alone is ambiguous along its depth). A candidate on the line whose
    3D point the marker cannot have reached is refused for this track for good: a later,
    looser gate (the marker unseen for longer) must not overrule the tightest evidence,
    which is the first.
    """
    other = state.other(camera)
    close = on_epipolar_line(state.cameras[camera], state.cameras[other], uv, candidates,
                             state.config.epipolar_px)
    if not close:
        return UNNUMBERED
    xyz, _ = triangulate_pairs(state.cameras[camera], state.cameras[other],
                               np.repeat(uv[None], len(close), 0),
                               np.array([candidates[m] for m in close]))
    fits = []
    for m, x in zip(close, xyz, strict=True):
        if m in state.positions.known:
            if stamp_s - state.positions.known[m][0] > MAX_DEPTH_AGE_S:
                continue  # no recent 3D point: nothing to check the depth along the line
            dist, allowed = state.positions.distance(m, stamp_s, x)
        else:  # never triangulated: its grid point, while that is recent and unseen here
            anchor = grid_anchor(state, camera, m, stamp_s)
            if anchor is None or nearer_grid_point(state, camera, m, uv) is not None:
                continue
            dist = float(np.linalg.norm(x - anchor[0]))
            allowed = anchor[1]
        if dist <= allowed:
            fits.append(m)
            continue
        state.refused[camera].add((track_id, m))
        events.append(f'{camera}: track {track_id} is not marker {m}: on its epipolar line '
                      f'but {1e3 * dist:.0f} mm from its last position (at most '
                      f'{1e3 * allowed:.0f} mm)')
    if len(fits) != 1:
        return UNNUMBERED
    state.counts[camera].numbered_by_epipolar += 1
    events.append(f'{camera}: track {track_id} numbered marker {fits[0]} by the epipolar '
                  'line')
    return fits[0]
