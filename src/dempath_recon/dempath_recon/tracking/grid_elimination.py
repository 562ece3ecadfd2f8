"""A marker seen by one camera only, numbered by elimination: the grid point it started nearest
among the markers nobody holds.

The grid fit (:func:`~dempath_recon.tracking.associate.number_by_grid`) numbers a spot only when
the next-nearest grid point lies half a gate farther than its own: an oblique view packs the
grid's rows 13-15 px apart, and a marker the bed has already moved 5-10 px from its grid point
before the first frame sits nearly as near a neighbour's point. Such a spot is left unnumbered,
and when the other camera does not see that marker (covered in its view, or less than half
visible) nothing numbers it later: the epipolar line and the pair rules need the other camera.
On eight tuning renders at session 18's start half of the found-but-unnumbered marker-frames
(152 of 297) were markers the other camera did not show (side marker 13 of one render: found in
all 17 frames, 7 px from its fitted grid point, never numbered).

The neighbours it was refused for are mostly numbered by then, on their own spots: they are not
where it is. So among the markers no track of either camera holds and neither camera has given
out, an unnumbered track takes the one whose fitted grid point its first position lies nearest
(:func:`number_by_elimination`), when

- that point lies within ``grid_gate_px`` and every other such point at least ``SECOND_RATIO``
  times as far;
- every other marker whose grid point lies within that reach is seen on a spot of its own in
  this camera's frame (a marker this camera lost, or holds no track of, may be this spot);
- no other unnumbered track of the camera started nearest the same point;
- the track started within ``START_WINDOW_S`` of the camera's grid fit (later a marker has moved
  on from where the fit placed it) and kept its links (never re-attached);
- no unnumbered spot of the other camera lies on its epipolar line (the pair rules decide;
  with ``StereoTrackConfig.line_rival`` only a spot whose pair may be a marker nobody holds,
  :mod:`~dempath_recon.tracking.line_rival`), nor a marker the other camera gives out and this
  one holds no track of (a marker coming out of the sand, seen here only now);
- neither camera's numbers are provisional (the fit of both in 3D replaces them).

No pair check watches a marker only one camera sees, so a number given so is watched until one
passes: it is taken back for good when its track jumps (re-attached, or linked farther than
``doubt_link_px`` from its prediction: :func:`revoke_jumped`) or its spot may hold a neighbour
lost beside it (:func:`revoke_shared`), since when the two part the track may follow the
other. A contradicting pair check of the other camera takes it back as any late number
(:func:`~dempath_recon.tracking.pair_checks.verify`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import epipolar_distance
from dempath_recon.tracking.line_rival import may_be_free, may_be_given, neighbours_settled
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.state import StereoState, take_back

FloatArray = NDArray[np.float64]
LINE_FACTOR = 3.0  # a marker the other camera gives out and this one holds no track of may be
# the spot when the spot lies within this many times ``epipolar_px`` of its line (a marker coming
# out of the sand, seen by this camera only now, 1-2 px off at half visible)
SECOND_RATIO = 2.0  # the next free grid point must be this many times as far as the nearest
START_WINDOW_S = 0.03  # tracks born this long after the grid fit at most (the next frame)


def number_by_elimination(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                          markers: NDArray[np.int32], uv: FloatArray, stamp_s: float,
                          events: list[str]) -> NDArray[np.int32]:
    """``markers`` (one frame's track numbers of ``camera``, -1: none) with the unnumbered
    tracks this camera alone sees numbered by elimination (module docstring); a track with an
    unnumbered spot of the other camera's latest frame on its epipolar line is left to the pair
    rules."""
    grid_uv = state.grid_uv.get(camera)
    other = state.other(camera)
    if not grid_uv or not (markers < 0).any() or state.last_stamp[other] is None \
            or state.provisional & {camera, other}:  # the joint fit has not numbered yet
        return markers
    fit_time = state.grid_time.get(camera, 0.0)
    held = {t.marker for c in state.cameras for t in state.trackers[c].tracks if t.marker >= 0}
    given = {m for c in state.cameras for m in state.latest[c]}
    free = [m for m in grid_uv if m not in held and m not in given
            and not (markers == m).any()]
    if not free:
        return markers
    free_uv = np.array([grid_uv[m] for m in free], np.float64)
    all_ids = list(grid_uv)
    all_uv = np.array([grid_uv[m] for m in all_ids], np.float64)
    seen = set(markers[markers >= 0].tolist())  # markers on their own spots in this frame
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    claims: dict[int, list[int]] = {}  # free marker -> the rows whose start lies nearest it
    beside: dict[int, list[int]] = {}  # row -> the other markers whose grid point is as near
    for k in np.flatnonzero(markers < 0).tolist():
        track = tracks.get(int(track_ids[k]))
        if track is None or track.reattached is not None or not track.history \
                or track.track_id in state.ray_wait.get(camera, {}):  # others on its line
            continue
        born, u0, v0 = track.history[0]
        if born > fit_time + START_WINDOW_S:
            continue
        d = np.linalg.norm(free_uv - np.array([u0, v0]), axis=1)
        order = np.argsort(d)
        near = float(d[order[0]])
        second = float(d[order[1]]) if len(order) > 1 else np.inf
        m = free[int(order[0])]
        if near > state.config.grid_gate_px or second < SECOND_RATIO * near \
                or (int(track_ids[k]), m) in state.refused[camera]:
            continue
        # every other marker whose grid point is about as near is seen on its own spot now
        # (a marker this camera lost, or holds no track of, may be this spot)
        d_all = np.linalg.norm(all_uv - np.array([u0, v0]), axis=1)
        radius = max(state.config.grid_gate_px, SECOND_RATIO * near)
        beside[k] = [n for n, dn in zip(all_ids, d_all, strict=True) if dn < radius and n != m]
        if any(n not in seen for n in beside[k]):
            continue
        claims.setdefault(m, []).append(k)
    if not claims:
        return markers
    out = markers.copy()
    for m, rows in claims.items():
        if len(rows) != 1:
            continue
        k = rows[0]
        if other_decides(state, camera, uv[k], stamp_s, state.config.line_rival):
            continue
        if state.config.line_rival and other_decides(state, camera, uv[k], stamp_s) \
                and not neighbours_settled(state, camera, track_ids, markers, beside[k]):
            continue  # let through by line_rival alone, the neighbours' numbers must be settled
        tid = int(track_ids[k])
        state.trackers[camera].number(tid, m)
        state.late_numbered[camera].add(tid)
        state.eliminated[camera][tid] = (stamp_s, tracks[tid].link_px)
        state.counts[camera].numbered_by_elimination += 1
        out[k] = m
        events.append(f'{camera}: track {tid} numbered marker {m} by elimination: it started '
                      'nearest its grid point among the markers nobody holds')
    return out


def other_decides(state: StereoState, camera: str, point: FloatArray, stamp_s: float,
                  rivals_in_3d: bool = False) -> bool:
    """Whether the other camera's latest frame (within a frame period) has an unnumbered spot
    on ``point``'s epipolar line, or gives out a marker this camera holds no track of within
    ``LINE_FACTOR`` times ``epipolar_px`` of it: the pair rules decide such a spot, not one
    camera's (elimination, :mod:`~dempath_recon.tracking.coming_out`). With ``rivals_in_3d``
    an unnumbered spot on the line counts only when its pair may be a marker nobody holds
    (:func:`~dempath_recon.tracking.line_rival.may_be_free`), and a marker the other camera
    gives out only when their pair lies near where the bed carried it
    (:func:`~dempath_recon.tracking.line_rival.may_be_given`)."""
    other = state.other(camera)
    period = 1.0 / state.config.fps
    free_o = state.free[other]
    mine = {t.marker for t in state.trackers[camera].tracks if t.marker >= 0}
    theirs = [(m, p) for m, (t, p) in state.latest[other].items()
              if m not in mine and abs(t - stamp_s) <= period]
    spots = free_o[2] if free_o is not None and abs(free_o[0] - stamp_s) <= period else None
    if rivals_in_3d:
        return (spots is not None and may_be_free(state, camera, point, spots, stamp_s)) \
            or may_be_given(state, camera, point, dict(theirs),
                            LINE_FACTOR * state.config.epipolar_px, stamp_s)
    return on_a_line(state, camera, point, spots, state.config.epipolar_px) \
        or on_a_line(state, camera, point, np.array([p for _, p in theirs]) if theirs else None,
                     LINE_FACTOR * state.config.epipolar_px)


def on_a_line(state: StereoState, camera: str, uv: FloatArray, uv_o: FloatArray | None,
               gate_px: float) -> bool:
    """Whether ``camera``'s spot ``uv`` (2,) lies within ``gate_px`` of the epipolar line of
    any of the other camera's spots ``uv_o`` (k, 2) (None: none)."""
    if uv_o is None or not len(uv_o):
        return False
    d = epipolar_distance(state.cameras[camera], state.cameras[state.other(camera)],
                          uv[None], np.asarray(uv_o, np.float64).reshape(-1, 2))
    return bool((d <= gate_px).any())


def revoke_jumped(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                  markers: NDArray[np.int32], events: list[str]) -> NDArray[np.int32]:
    """``markers`` with the numbers given by elimination taken back (for good, for that track)
    from tracks that jumped since: re-attached after a loss, or linked farther than
    ``doubt_link_px`` from their prediction. Only this camera sees such a marker, so no pair
    check would catch its track moving onto a neighbour's spot when the marker goes under
    (on two renders the track of a marker numbered so took a neighbour's spot a few frames
    later and kept its number, 5 switches each); once a pair check of the other camera passes,
    the track is checked like any other and no longer watched here. A number taken back for a
    link (no re-attachment since it was given) is noted in ``state.jumped``: a marker the tool
    starts pushing leaves its prediction with its track still on it, and
    :mod:`~dempath_recon.tracking.regain` gives the number back once both cameras pair it."""
    watched = state.eliminated[camera]
    if not watched:
        return markers
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    out = markers.copy()
    for tid, (since, link_px) in list(watched.items()):
        track = tracks.get(tid)
        if track is None or track.marker < 0:
            del watched[tid]
            continue
        if state.confirmed[camera].get(tid, -np.inf) > since:
            del watched[tid]
            continue
        jumped = (track.reattached is not None and track.reattached[0] > since) \
            or track.link_px > max(link_px, state.config.doubt_link_px)
        if not jumped:
            continue
        m = track.marker
        del watched[tid]
        if track.reattached is None or track.reattached[0] <= since:  # a link, kept since
            state.jumped[camera][tid] = (m, since)
        state.late_numbered[camera].discard(tid)
        take_back(state, camera, tid, m)
        out[track_ids == tid] = UNNUMBERED
        events.append(f'{camera}: track {tid} gave back marker {m} (numbered by elimination): '
                      'it jumped since')
    return out


def revoke_shared(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                  shared: NDArray[np.bool_], events: list[str]) -> None:
    """Take back for good the numbers given by elimination of the tracks whose spot may hold a
    neighbour lost beside it this frame (``shared``: (k,) per detection,
    :func:`~dempath_recon.tracking.link_guide.ambiguous_spots`): when the two part, the
    track may follow the other one, and no pair check watches a marker only this camera sees
    (on a dusk render the track of marker 1 went on with marker 6 after they shared a spot)."""
    watched = state.eliminated[camera]
    for tid in {int(t) for t in track_ids[shared]} & set(watched):
        track = next(t for t in state.trackers[camera].tracks if t.track_id == tid)
        del watched[tid]
        if track.marker < 0:
            continue
        events.append(f'{camera}: track {tid} gave back marker {track.marker} (numbered by '
                      'elimination): its spot may hold a neighbour')
        state.late_numbered[camera].discard(tid)
        take_back(state, camera, tid, track.marker)
