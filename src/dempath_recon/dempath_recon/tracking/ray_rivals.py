"""A marker only one camera shows at the grid fit, numbered only when no other marker could be
it along that camera's line of sight; else its track waits until the pass rules the others out.

At the grid fit a spot that no pair explains takes the number of its camera's image grid point
(:func:`~dempath_recon.tracking.numbering.one_camera_grid`). One camera alone gives no depth:
the spot may be any marker whose place lies on its line of sight. In 3D the fit knows where
the markers rest (the grid, shifted as the pairs place it), and the markers the pairs explain
are elsewhere; so a spot's *rivals* are the other markers no spot of its camera holds whose
shifted grid point lies within ``RIVAL_SHARE`` of the grid's pitch of the spot's line of sight,
except those the other camera gives out off the spot's epipolar line (it sees them elsewhere).

Why a reach and not odds: markers only one camera shows are the displaced and half-buried ones,
so the pairs' own scatter about their grid points (2.3-3.6 mm RMS on 36 tuning looks) says
little of them. On a low view a marker sunk a few mm lies on the line of sight of its
neighbour's grid point behind it (heldout27 ``T287_asis``: the front's spot of marker 12, 8.8
mm below the pairs' height and 7 mm forward, its side view buried, passed 2.5 mm from 13's grid
point and 11.5 mm from its own; numbered 13, 18 switches): odds from the pairs' scatter put 13
700 times likelier. Where this kind of number was right on those looks, the line of sight
passed 0.5-7.7 mm from the marker's own grid point. Half a pitch is the largest displacement
the grid can still attribute to a marker (beyond it the marker is nearer a neighbour's grid
point): a rival within it cannot be told apart by where it rests.

A spot with rivals is left unnumbered and its track waits with its candidates (the grid
number and the rivals; ``StereoState.ray_wait``); each frame, :func:`resolve_waiting` rules a
candidate out when this camera holds it on another track or the other camera gives it out off
the track's epipolar line, and numbers the track when one candidate is left that nobody holds.
Meanwhile the rules that number by one camera's grid alone (the late grid point, elimination)
pass it by, and a number outside its candidates that a pair rule gives it is taken back and
refused (:func:`keep_candidates`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import epipolar_distance, normalised
from dempath_recon.tracking.grid_pairs import grid_pitch
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.state import RECENT_S, StereoState, at_stamp

FloatArray = NDArray[np.float64]
RIVAL_SHARE = 0.5  # a marker whose grid point lies within this share of the pitch of a spot's
# line of sight could be that spot (half a pitch: 12.5 mm on the 25 mm grid; the true places
# of markers one camera showed at the fit lay up to 11.6 mm off their shifted grid points)


def line_distances(cam: Camera, uv: FloatArray, points: FloatArray) -> FloatArray:
    """(n, m) distance [m] of each world point (m, 3) from the line of sight of each spot
    (n, 2) px of ``cam`` (the ray through the camera's centre, undistorted)."""
    xn = normalised(cam, uv)
    rot = np.asarray(cam.R, np.float64)
    centre = -rot.T @ np.asarray(cam.t, np.float64).ravel()
    rays = np.column_stack([xn, np.ones(len(xn))]) @ rot  # (n, 3): R^T [x, y, 1]
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    rel = np.asarray(points, np.float64) - centre  # (m, 3)
    along = rays @ rel.T  # (n, m)
    sq = np.maximum((rel ** 2).sum(axis=1)[None] - along ** 2, 0.0)
    return np.asarray(np.sqrt(sq), np.float64)


def hold_rivals(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                uv: FloatArray, numbers: NDArray[np.int32], alone: NDArray[np.bool_],
                uv_o: FloatArray, numbers_o: NDArray[np.int32], shift: FloatArray,
                events: list[str]) -> NDArray[np.int32]:
    """``numbers`` (n,) of ``camera``'s spots ``uv`` (n, 2) px at the grid fit, with each spot
    numbered by its camera alone (``alone``) that has rivals (module docstring) left
    unnumbered, its track waiting in ``state.ray_wait`` with its candidates. Rivals are
    markers no spot of this camera keeps: a spot refused frees its number, which may then be
    another spot's rival (repeated until nothing changes). ``uv_o``/``numbers_o``: the other
    camera's spots and numbers at the fit; ``shift`` (3,) m: the grid's fitted 3D offset."""
    ids, grid_xyz = state.config.grid.points()
    if not alone.any():
        return numbers
    cam, cam_o = state.cameras[camera], state.cameras[state.other(camera)]
    reach = RIVAL_SHARE * grid_pitch(state.config.grid)
    near = line_distances(cam, uv, grid_xyz + shift) < reach  # (n, markers)
    off_line = epipolar_distance(cam, cam_o, uv, uv_o) > state.config.epipolar_px \
        if len(uv_o) else np.zeros((len(uv), 0), bool)
    out = numbers.copy()
    waits: dict[int, set[int]] = {}
    changed = True
    while changed:
        changed = False
        held = set(out[out >= 0].tolist())
        for i in np.flatnonzero(alone & (out >= 0)).tolist():
            seen_off = set(numbers_o[off_line[i] & (numbers_o >= 0)].tolist())
            rivals = {int(m) for m in ids[near[i]].tolist()
                      if m != out[i] and m not in held and m not in seen_off}
            if rivals:
                waits[i] = rivals | {int(out[i])}
                out[i] = UNNUMBERED
                changed = True
    wait = state.ray_wait.setdefault(camera, {})
    for i, cands in waits.items():
        wait[int(track_ids[i])] = cands
        events.append(f'{camera}: track {int(track_ids[i])} not numbered by the grid alone: '
                      f'markers {sorted(cands)} all lie on its line of sight')
    return out


def resolve_waiting(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                    markers: NDArray[np.int32], uv: FloatArray, stamp_s: float,
                    events: list[str]) -> NDArray[np.int32]:
    """``markers`` (k,) of this frame's spots ``uv`` (k, 2) px with each waiting track
    (``state.ray_wait``) numbered once one candidate is left: a candidate is ruled out when
    this camera holds it on another track, or the other camera gave it out within
    ``RECENT_S`` at a point (moved to this stamp) off the track's epipolar line. A track gone,
    or with no candidate left, stops waiting; one numbered meanwhile (by a rule of both
    cameras) or re-attached keeps its candidates (:func:`keep_candidates`) but is not numbered
    here."""
    wait = state.ray_wait.get(camera)
    if not wait:
        return markers
    other = state.other(camera)
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    index = {int(t): k for k, t in enumerate(track_ids.tolist())}
    out = markers.copy()
    for tid in list(wait):
        track = tracks.get(tid)
        if track is None:
            del wait[tid]
            continue
        if track.marker >= 0 or track.reattached is not None:  # numbered among its candidates
            continue  # by a rule of both cameras, or re-attached (it may be on another spot)
        holders = {t.marker for t in tracks.values() if t.track_id != tid and t.marker >= 0}
        cands = wait[tid] - holders
        k = index.get(tid)
        if k is not None:
            cands = {m for m in cands if not _seen_off_line(state, camera, m, uv[k], stamp_s)}
        wait[tid] = cands
        if not cands:  # every candidate given out elsewhere: the fit's reach did not hold
            del wait[tid]
            continue
        if len(cands) > 1 or k is None:
            continue
        m = next(iter(cands))
        if (tid, m) in state.refused[camera] or m in out.tolist() or m in holders:
            continue
        state.trackers[camera].number(tid, m)
        state.late_numbered[camera].add(tid)
        state.counts[camera].numbered_by_grid_late += 1
        out[k] = m
        events.append(f'{camera}: track {tid} numbered marker {m}: the other markers on its '
                      f'line of sight at the grid fit are given out elsewhere ({other} or here)')
    return out


def _seen_off_line(state: StereoState, camera: str, marker: int, uv: FloatArray,
                   stamp_s: float) -> bool:
    """Whether the other camera gave ``marker`` out within ``RECENT_S`` at a point (moved to
    ``stamp_s`` along its track) farther than ``epipolar_px`` from the line of ``uv`` (2,)."""
    other = state.other(camera)
    sighting = state.latest[other].get(marker)
    if sighting is None or abs(sighting[0] - stamp_s) > RECENT_S:
        return False
    p = at_stamp(state, other, marker, sighting, stamp_s)
    d = epipolar_distance(state.cameras[camera], state.cameras[other], uv[None], p[None])
    return bool(d[0, 0] > state.config.epipolar_px)


def keep_candidates(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                    markers: NDArray[np.int32], events: list[str]) -> NDArray[np.int32]:
    """``markers`` (k,) with each waiting track (``state.ray_wait``) that a rule numbered
    outside its candidates unnumbered again, that number refused to it: at the grid fit its
    marker rested within reach of its line of sight, and every marker that did and no other
    spot of its camera held is among its candidates (a pair rule's partner on its line at
    another marker's depth does not move the marker it is)."""
    wait = state.ray_wait.get(camera)
    if not wait:
        return markers
    out = markers.copy()
    for k, tid in enumerate(track_ids.tolist()):
        cands = wait.get(int(tid))
        m = int(out[k])
        if cands is None or m < 0 or m in cands:
            continue
        state.trackers[camera].number(int(tid), UNNUMBERED)
        state.refused[camera].add((int(tid), m))
        out[k] = UNNUMBERED
        events.append(f'{camera}: track {tid} not marker {m}: at the grid fit its line of sight '
                      f'passed only markers {sorted(cands)}')
    return out
