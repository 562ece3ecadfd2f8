"""The two-camera tracker's numbering of a marker only one camera sees: an unnumbered track
that has run steadily for a few frames takes the number of the one marker the bed has carried
onto its line of sight.

A marker covered in one view (the tine's heap, a neighbour in front) never gets a number from
the other camera's epipolar line nor as a pair; until now it stayed unnumbered for as long as
the other camera could not see it (on the bundled render: marker 11 in the side camera for the
last 9 frames, the front camera seeing at most 17 % of it). Its own camera's line of sight
still says much: every marker has a place the bed has carried it to (``carried_point``), and
when exactly one marker that this frame does not show elsewhere lies near the line, and every
other is several times as far, the spot is that marker. The number is taken back if a later
pair contradicts it (``verify``, as for every late number).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import back_project
from dempath_recon.tracking.linker import Track
from dempath_recon.tracking.state import (
    CARRY_FLOOR_M,
    StereoState,
    carried_point,
    retire,
    unnumbered_tracks,
)

FloatArray = NDArray[np.float64]
STEADY_FRAMES = 3  # frames a track must have been linked without a gap before it is numbered
# on one camera's evidence (a spot seen once may be noise or a neighbour's edge)
RAY_RATIO = 3.0  # the nearest marker to the line of sight wins when every other candidate is
# this many times as far (stricter than the pair numbering's 2.5: one camera, no depth)
RAY_GATE_M = 0.025  # farthest a marker's carried place may lie from the line of sight [m]
# (the carried place of a marker covered for half a second was 4.5 mm off on the bundled render;
# a marker's diameter and a half beyond that is no longer evidence)


def number_by_ray(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                  markers: NDArray[np.int32], uv: FloatArray, stamp_s: float,
                  events: list[str]) -> NDArray[np.int32]:
    """Number unnumbered steady tracks of ``camera`` by the markers' carried places.

    For each unnumbered track linked without a gap over its last ``STEADY_FRAMES`` frames,
    every grid marker not numbered in this frame is a candidate, placed where the bed has
    carried it (:func:`~dempath_recon.tracking.state.carried_point`). The track is numbered
    as the candidate nearest its line of sight when that one lies within ``RAY_GATE_M`` and
    within what the marker can have reached, and every other candidate is at least
    ``RAY_RATIO`` times as far (at least ``CARRY_FLOOR_M``). A candidate that cannot be
    placed could be anywhere: then nothing is numbered. A number refused to the track before
    is not given, nor a marker this camera gave out since the track started (it ran beside
    the track: the epipolar numbering's rule).
    """
    todo = np.flatnonzero(unnumbered_tracks(state, camera, track_ids, markers))
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    gap = 1.5 / state.config.fps
    doubtful = [k for k in np.flatnonzero(markers >= 0).tolist()
                if (t := tracks.get(int(track_ids[k]))) is not None
                and t.reattach_px > state.config.doubt_link_px and steady(t, STEADY_FRAMES, gap)]
    if not len(todo) and not doubtful:
        return markers
    sure = {int(m) for k, m in enumerate(markers) if m >= 0 and k not in doubtful}
    places: dict[int, tuple[FloatArray, float]] = {}
    for m in state.config.grid.points()[0].tolist():
        if m in sure:
            continue
        placed = carried_point(state, m, stamp_s)
        if placed is None:
            return markers
        places[m] = placed
    cam = state.cameras[camera]
    centre = -np.asarray(cam.R, np.float64).T @ np.asarray(cam.t, np.float64)
    markers = markers.copy()
    for k in doubtful:  # a re-attached track not yet confirmed, on another marker's line
        tid, own = int(track_ids[k]), int(markers[k])
        number, note = _nearest(state, cam, centre, uv[k], places, stamp_s)
        if number < 0 or number == own or number in markers or (tid, number) in \
                state.refused[camera]:
            continue
        state.refused[camera].add((tid, own))
        state.counts[camera].revoked += 1
        _give(state, camera, tracks[tid], number)
        events.append(f'{camera}: track {tid} re-attached as marker {own} renumbered marker '
                      f'{number}: the one marker the bed carried onto its line of sight '
                      f'({note})')
        markers[k] = number
    taken = {int(m) for m in markers if m >= 0}
    for m in taken:
        places.pop(m, None)
    for k in todo.tolist():
        tid = int(track_ids[k])
        track = tracks.get(tid)
        if track is None or not steady(track, STEADY_FRAMES, gap):
            continue
        # a marker this camera gave out since the track started ran beside it: not this one
        start = track.history[0][0]
        unseen = {m: p for m, p in places.items()
                  if state.latest[camera].get(m, (-np.inf, None))[0] < start}
        number, note = _nearest(state, cam, centre, uv[k], unseen, stamp_s)
        if number < 0 or (tid, number) in state.refused[camera]:
            continue
        _give(state, camera, track, number)
        events.append(f'{camera}: track {tid} numbered marker {number}: the one marker the '
                      f'bed carried onto its line of sight ({note})')
        markers[k] = number
        del places[number]
    return markers


def _nearest(state: StereoState, cam: Camera, centre: FloatArray, uv: FloatArray,
             places: dict[int, tuple[FloatArray, float]], stamp_s: float) -> tuple[int, str]:
    """The marker of ``places`` nearest the line of sight through ``uv`` when it is within
    ``RAY_GATE_M`` and its reach and every other is ``RAY_RATIO`` times as far; else -1."""
    if not places:
        return -1, ''
    ray = back_project(cam, uv, 1.0) - centre
    ray /= np.linalg.norm(ray)
    ranked = sorted((_off_ray(at, centre, ray), m) for m, (at, _) in places.items())
    dist, number = ranked[0]
    reach = state.config.position_gate_m + state.config.max_speed_m_s * (
        stamp_s - places[number][1])
    if dist > min(RAY_GATE_M, reach):
        return -1, ''
    if len(ranked) > 1 and ranked[1][0] < RAY_RATIO * max(dist, CARRY_FLOOR_M):
        return -1, ''
    nxt = f'{1e3 * ranked[1][0]:.1f} mm' if len(ranked) > 1 else 'none'
    return number, f'{1e3 * dist:.1f} mm; the next {nxt}'


def _give(state: StereoState, camera: str, track: Track, number: int) -> None:
    """Number ``track`` by its line of sight (a late number: a later pair may take it back)."""
    retire(state, camera, number)
    state.trackers[camera].number(track.track_id, number)
    # the doubts of an earlier re-attachment were about the number it had; the new one rests
    # on the steady track's own line of sight, and its first pair is checked as a re-attached
    # track's is: against every marker the bed could have carried to the pair's 3D point
    track.reattach_px = track.link_px = 0.0
    track.back_unchecked = True
    state.late_numbered[camera].add(track.track_id)
    state.counts[camera].numbered_by_ray += 1


def steady(track: Track, frames: int, gap_s: float) -> bool:
    """Whether ``track``'s last ``frames`` sightings follow each other without a gap."""
    if len(track.history) < frames:
        return False
    stamps = [h[0] for h in track.history[-frames:]]
    return bool(np.all(np.diff(stamps) <= gap_s))


def _off_ray(point: FloatArray, centre: FloatArray, ray: FloatArray) -> float:
    """Distance [m] of ``point`` (3,) from the line of sight ``centre + s * ray`` (s >= 0)."""
    rel = point - centre
    along = max(float(rel @ ray), 0.0)
    return float(np.linalg.norm(rel - along * ray))
