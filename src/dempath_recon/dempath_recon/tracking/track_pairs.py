"""The two-camera tracker's numbering of a track left unnumbered, decided again over time: its
pair with a track of the other camera that has held on its epipolar line for several frames.

The numberings of one frame (the grid fit, the epipolar line, the pair of two unnumbered spots)
leave a track unnumbered when that frame alone is ambiguous, and nothing decides it again: a
spot on the line of two markers of the other camera, one behind the other along its line of
sight, is refused both numbers at the grid fit (``numbering.number_both_by_grid``) and stays
unnumbered for the whole pass, though both cameras see it (on a tuning render the front's spot
of marker 8, with 7 hidden behind it, 17 frames; the side's spot of 10, with 5 behind it, 17
frames). Here each unnumbered track of a camera is compared with the other camera's running
tracks over their last ``PAIR_FRAMES`` common frames (:mod:`~dempath_recon.tracking.held_line`:
within ``epipolar_px`` in every frame, and on average within a few times the distance of the
pairs numbered now). Each partner's pair is triangulated now and named: a numbered partner's
marker, an unnumbered partner's one missing marker, when that marker is the only one the bed
can have carried there (:func:`~dempath_recon.tracking.pair_numbering.only_marker`) and lies
within ``CARRIED_GATE_M`` of it. Along a line of sight a camera sees the nearest marker (one
behind it is hidden), so of the partners the one whose pair lies nearest this camera is taken
when every other lies a marker's diameter farther (``_nearest``), and the track must be, of
this camera's tracks on the partner's line, the one nearest the partner's camera
(``_seen_by_partner``). A numbered partner whose marker was never triangulated (it came out of the
sand in this camera only now) is often carried poorly: with ``StereoTrackConfig.numbered_partner``
(off by default) the test is then done again, when no other track of the other camera lies on this
track's line at a pair nearer this camera (``_alone_on_line``: it could hide the partner's marker
from this camera), with only the markers the other camera does not see on a running track as rivals
(a marker it sees elsewhere is not on this line of sight) and ``NUMBERED_GATE_M`` as the gate
(``_numbered_partner``). Numbers the grid fit refused a merged spot (``state.fit_merged``) may
be given here, once the other camera holds each other marker of that spot off the spot's line
(``_still_behind``: until then it may show beside the near one and pull the centre between);
other refusals hold. The numbers reach the frames still held by the publication delay through
``release.renumber``; each is checked at once by ``pair_checks.verify`` and taken back if a
later pair contradicts it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import (
    depth,
    epipolar_distance,
    marker_diameter_px,
    project,
    triangulate_pairs,
)
from dempath_recon.tracking.held_line import held_on_line, track_at
from dempath_recon.tracking.linker import UNNUMBERED, Track
from dempath_recon.tracking.pair_numbering import only_marker
from dempath_recon.tracking.release import unbroken
from dempath_recon.tracking.state import (
    RECENT_S,
    StereoState,
    carried_point,
    give_late,
    sure_numbers,
)

FloatArray = NDArray[np.float64]
CARRIED_GATE_M = 0.015  # a pair's 3D point lies this near where the bed carried its marker [m]
NUMBERED_GATE_M = 0.03  # ... for a partner the other camera numbers, alone on the line [m]: a
# marker never triangulated is carried from its grid point with its neighbours, and a tool
# pushes it ahead of them (right pairs lay 13-32 mm off on tuning and seed-87 renders); still
# under a grid pitch (50 mm), and another marker's carried point must be 2.5 times as far
BESIDE_SHARE = 1.0  # a marker held by neither camera carried within this many diameters of a
# spot may share it
PAIR_FRAMES = 4  # common frames a pair must hold on the epipolar line (0.08 s at 50 FPS): on
# a tuning render a wrong partner stayed on the line for 11 frames, so the line alone is not
# enough, but a partner that crossed it once in passing is left out


class Partner(NamedTuple):
    """A track of the other camera that held on a track's epipolar line."""

    track_id: int  # the other camera's track
    marker: int  # the marker their pair is (-1: none can be named)
    depth_m: float  # the pair's depth in this camera [m]


def number_by_track_pairs(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                          markers: NDArray[np.int32], uv: FloatArray, stamp_s: float,
                          events: list[str]) -> NDArray[np.int32]:
    """``markers`` (k,) with this frame's unnumbered tracks numbered by a partner track of the
    other camera that held on their epipolar line over their last ``PAIR_FRAMES`` common
    frames (see the module's docstring); ``uv`` (k, 2) px are the frame's points of
    ``track_ids`` (k,). An unnumbered partner takes the number too."""
    other = state.other(camera)
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    numbered = {t.track_id for t in tracks.values() if t.marker >= 0}
    todo = [k for k in np.flatnonzero(markers < 0).tolist()
            if int(track_ids[k]) not in numbered
            and len(tracks[int(track_ids[k])].history) >= PAIR_FRAMES]
    period = 1.0 / state.config.fps
    partners = [t for t in state.trackers[other].tracks
                if not t.lost and abs(t.last_stamp_s - stamp_s) <= period
                and len(t.history) >= PAIR_FRAMES]
    if not todo or not partners:
        return markers
    now = np.array([t.uv + t.velocity * (stamp_s - t.last_stamp_s) for t in partners])
    near = epipolar_distance(state.cameras[camera], state.cameras[other], uv[todo], now) \
        <= state.config.epipolar_px  # (todo, partners): this frame first, the cheap test
    held = {int(m) for m in sure_numbers(state, camera, track_ids, markers) if m >= 0}
    given_o = {m for m, (t, _) in state.latest[other].items() if abs(t - stamp_s) <= RECENT_S}
    out = markers.copy()
    for row, k in enumerate(todo):
        if not near[row].any():
            continue
        track = tracks[int(track_ids[k])]
        found = _partners(state, camera, track, [p for p, n in zip(partners, near[row],
                                                                   strict=True) if n],
                          uv[k], stamp_s, held, given_o)
        chosen = _nearest(found, state.config.marker_diameter_m)
        if chosen is None:
            continue
        partner = next(t for t in partners if t.track_id == chosen[0])
        number = chosen[1]
        if not _seen_by_partner(state, camera, track, partner, stamp_s) \
                or _still_behind(state, camera, track, number, partners) \
                or _missing_beside(state, camera, number, uv[k], stamp_s, held):
            continue
        give_late(state, camera, track, number)
        if partner.marker < 0:
            give_late(state, other, partner, number)
            state.latest[other][number] = (partner.last_stamp_s, partner.uv.copy())
        out[k] = number
        held.add(number)
        events.append(f'{camera}: track {track.track_id} numbered marker {number} with '
                      f'{other} track {partner.track_id}: on its epipolar line for '
                      f'{PAIR_FRAMES} frames, the pair nearest this camera')
        state.counts[camera].numbered_by_track_pair += 1
    return out


def _partners(state: StereoState, camera: str, track: Track, partners: list[Track],
              uv: FloatArray, stamp_s: float, held: set[int], given_o: set[int],
              ) -> list[Partner]:
    """The other camera's tracks that held on ``track``'s epipolar line over their last
    ``PAIR_FRAMES`` common frames, each with the marker its pair now is (-1: none can be
    named) and the pair's depth in ``camera`` [m]."""
    fps = state.config.fps
    recent = track.history[-PAIR_FRAMES:]
    if not unbroken(track, recent[0][0], fps):
        return []
    other = state.other(camera)
    cam, cam_o = state.cameras[camera], state.cameras[other]
    mine = np.array([(u, v) for _, u, v in recent])
    stamps = [s for s, _, _ in recent]
    placed = [(p, at) for p in partners if (at := track_at(p, stamps, fps)) is not None]
    if not placed:
        return []
    n = len(recent)
    d = epipolar_distance(cam, cam_o, mine, np.vstack([at for _, at in placed]))
    kept: list[Track] = []
    moved: list[FloatArray] = []
    for i, (p, at) in enumerate(placed):  # frame f of mine against frame f of each partner
        if held_on_line(state, d[np.arange(n), i * n + np.arange(n)]):
            kept.append(p)
            moved.append(at[-1])
    if not kept:
        return []
    xyz, _ = triangulate_pairs(cam, cam_o, np.repeat(uv[None], len(kept), 0), np.array(moved))
    names = state.config.grid.points()[0].tolist()
    free = [m for m in names if m not in held]
    seen_o = {t.marker for t in state.trackers[other].tracks
              if t.marker >= 0 and not t.lost}  # markers the other camera sees now
    out = []
    for p, x in zip(kept, xyz, strict=True):
        if p.marker >= 0:
            number = _numbered_name(state, camera, uv, p, x, stamp_s, held, free, seen_o)
        else:
            number = only_marker(state, x, stamp_s, [m for m in free if m not in given_o])
            if number >= 0 and not _near_carried(state, number, x, stamp_s):
                number = UNNUMBERED
        if number >= 0 and not (_may_take(state, camera, track.track_id, number)
                                and _may_take(state, other, p.track_id, number)):
            number = UNNUMBERED
        out.append(Partner(p.track_id, number, depth(cam, x)))
    return out


def _numbered_name(state: StereoState, camera: str, uv: FloatArray, partner: Track,
                   xyz: FloatArray, stamp_s: float, held: set[int], free: list[int],
                   seen_o: set[int]) -> int:
    """The partner's number (it is numbered) for the pair's 3D point ``xyz`` (3,) m of this
    camera's spot ``uv`` (2,) px, else -1: the only marker of ``free`` (those this camera does
    not hold) the bed can have carried there, within ``CARRIED_GATE_M``; failing that, with
    ``StereoTrackConfig.numbered_partner`` and the partner alone on the line
    (``_alone_on_line``), the only one of the free markers the other camera does not see now
    (``seen_o``) besides it, within ``NUMBERED_GATE_M`` (``_numbered_partner``)."""
    number = only_marker(state, xyz, stamp_s, free)
    if number == partner.marker and _near_carried(state, number, xyz, stamp_s):
        return number
    if not state.config.numbered_partner \
            or not _alone_on_line(state, camera, uv, partner, stamp_s, held):
        return UNNUMBERED
    return _numbered_partner(state, xyz, stamp_s, partner.marker,
                             [m for m in free if m not in seen_o or m == partner.marker])


def _alone_on_line(state: StereoState, camera: str, uv: FloatArray, partner: Track,
                   stamp_s: float, held: set[int]) -> bool:
    """Whether every other running track of the other camera (of any age) whose point now lies
    within ``epipolar_px`` of the epipolar line of this camera's spot ``uv`` (2,) px pairs
    with it at least a marker's diameter farther from this camera than ``partner`` does
    (hidden behind the partner's marker), or holds a marker this camera holds elsewhere
    (``held``: explained there). A track on the line at a nearer pair may be a marker hiding
    the partner's from this camera (on a tuning render the front's spot of 8 lay on the line
    of the side's 7, hidden behind 8 in the front, while the side's 8 had been found two
    frames before: with any track counted there, 7 was taken, 7 switches)."""
    other = state.other(camera)
    period = 1.0 / state.config.fps
    now = [t.uv + t.velocity * (stamp_s - t.last_stamp_s) for t in state.trackers[other].tracks
           if not t.lost and abs(t.last_stamp_s - stamp_s) <= period
           and t.track_id != partner.track_id and t.marker not in held]
    if not now:
        return True
    cam, cam_o = state.cameras[camera], state.cameras[other]
    d = epipolar_distance(cam, cam_o, uv[None], np.array(now))[0]
    on = [p for p, dist in zip(now, d, strict=True) if dist <= state.config.epipolar_px]
    if not on:
        return True
    mine = partner.uv + partner.velocity * (stamp_s - partner.last_stamp_s)
    xyz, _ = triangulate_pairs(cam, cam_o, np.repeat(uv[None], len(on) + 1, 0),
                               np.array([mine, *on]))
    z = np.array([depth(cam, x) for x in xyz])
    return bool((z[1:] >= z[0] + state.config.marker_diameter_m).all())


def _numbered_partner(state: StereoState, xyz: FloatArray, stamp_s: float, marker: int,
                      rivals: list[int]) -> int:
    """``marker`` (the other camera's number of a partner) when the pair's 3D point ``xyz``
    (3,) m can be no other marker, else -1: of ``rivals`` (the markers this camera does not
    hold and the other camera does not see on a running track: a marker the other camera sees
    elsewhere is not on this line of sight) it is the only one the bed can have carried there
    (``only_marker``), and it lies within ``NUMBERED_GATE_M`` of where the bed carried it."""
    if only_marker(state, xyz, stamp_s, rivals) != marker:
        return UNNUMBERED
    return marker if _near_carried(state, marker, xyz, stamp_s, NUMBERED_GATE_M) \
        else UNNUMBERED


def _near_carried(state: StereoState, marker: int, xyz: FloatArray, stamp_s: float,
                  gate_m: float = CARRIED_GATE_M) -> bool:
    """Whether a pair's 3D point ``xyz`` (3,) m lies within ``CARRIED_GATE_M`` of where the bed
    has carried ``marker`` (``state.carried_point``). ``only_marker`` lets a marker reach as far
    as the fastest marker could have moved since it was placed, which after a few frames
    covers a spot 100 mm off on the same line of sight; the bed carries a marker with its
    neighbours, and right pairs here lay 5-9 mm from that (tuning renders)."""
    placed = carried_point(state, marker, stamp_s)
    return placed is not None and float(np.linalg.norm(xyz - placed[0])) <= gate_m


def _nearest(found: list[Partner], diameter_m: float) -> tuple[int, int] | None:
    """(partner's track id, marker) of the named pair nearest the camera, when every other
    partner's pair lies at least ``diameter_m`` farther (two markers on one line of sight are
    a diameter apart at least; nearer, the two pairs may be one marker); else None."""
    if not found:
        return None
    ranked = sorted(found, key=lambda f: f.depth_m)
    first = ranked[0]
    if first.marker < 0 or (len(ranked) > 1 and ranked[1].depth_m - first.depth_m < diameter_m):
        return None
    return first.track_id, first.marker


def _still_behind(state: StereoState, camera: str, track: Track, number: int,
                  partners: list[Track]) -> bool:
    """Whether another marker the grid fit saw in this track's merged spot
    (``state.fit_merged``) may still be in it: the other camera does not hold it on a running
    track now, or that track lies within ``epipolar_px`` of this track's epipolar line.
    Behind the marker nearer this camera, it may show beside it and pull the spot's centre
    between the two (on a tuning render with a 12 ms shutter the front's spot of markers 8
    and 7 was nearer 7's centre in 8 of its 17 frames, while the side's 7 stayed 0.6-2.4 px
    from its line)."""
    behind = state.fit_merged[camera].get(track.track_id, set()) - {number}
    if not behind:
        return False
    where = {t.marker: t.uv for t in partners if t.marker in behind}
    if set(where) != behind:
        return True
    d = epipolar_distance(state.cameras[camera], state.cameras[state.other(camera)],
                          track.uv[None], np.array(list(where.values())))
    return bool((d <= state.config.epipolar_px).any())


def _missing_beside(state: StereoState, camera: str, number: int, point: FloatArray,
                    stamp_s: float, held: set[int]) -> bool:
    """Whether a marker that neither camera holds now (not ``number``) lies, where the bed
    has carried it, within ``BESIDE_SHARE`` marker diameters of the spot ``point`` (2,) px in
    this camera: it may be in the spot beside the one numbered, pulling its centre between
    the two (on a tuning render with a 12 ms shutter the front's spot of marker 10 was nearer
    9's centre in 9 of its 16 frames; 9 was found in neither camera then). Markers that
    cannot be placed are not counted."""
    cam = state.cameras[camera]
    seen_o = {t.marker for t in state.trackers[state.other(camera)].tracks
              if t.marker >= 0 and not t.lost}
    size = marker_diameter_px(cam, state.config.grid, state.config.marker_diameter_m)
    for m in state.config.grid.points()[0].tolist():
        if m == number or m in held or m in seen_o:
            continue
        placed = carried_point(state, m, stamp_s)
        if placed is not None and float(np.linalg.norm(
                project(cam, placed[0][None])[0] - point)) < BESIDE_SHARE * size:
            return True
    return False


def _may_take(state: StereoState, camera: str, track_id: int, number: int) -> bool:
    """Whether a track may take ``number``: not refused it, or refused it only at the grid
    fit as a merged spot (``state.fit_merged``, kept after: it also says which markers were
    hidden at the fit)."""
    return (track_id, number) not in state.refused[camera] \
        or number in state.fit_merged[camera].get(track_id, set())


def _seen_by_partner(state: StereoState, camera: str, track: Track, partner: Track,
                     stamp_s: float) -> bool:
    """Whether ``track`` is what ``partner`` (the other camera's) sees: of this camera's
    running tracks that held on the partner's epipolar line over the last ``PAIR_FRAMES``
    frames, its pair with the partner lies nearest the other camera, every other at least a
    marker's diameter farther. A marker hidden behind the partner's along the other camera's
    line of sight pairs with it too, at its own depth (on a tuning render the front's spot of
    marker 9 held on the line of the side's 10, with 9 hidden behind 10 in the side, and took
    10)."""
    other = state.other(camera)
    fps = state.config.fps
    recent = partner.history[-PAIR_FRAMES:]
    cam, cam_o = state.cameras[camera], state.cameras[other]
    theirs = np.array([(u, v) for _, u, v in recent])
    elsewhere = {t.marker for t in state.trackers[other].tracks
                 if t.marker >= 0 and not t.lost and t.track_id != partner.track_id}
    rows: list[tuple[float, int]] = []
    for t in state.trackers[camera].tracks:
        if t.lost or abs(t.last_stamp_s - stamp_s) > 0.5 / fps or len(t.history) < PAIR_FRAMES \
                or t.marker in elsewhere:  # the other camera sees that one on another spot
            continue
        at = track_at(t, [s for s, _, _ in recent], fps)
        if at is None:
            continue
        d = epipolar_distance(cam_o, cam, theirs, at)
        if not held_on_line(state, np.diagonal(d)):
            continue
        xyz, _ = triangulate_pairs(cam_o, cam, theirs[-1:], at[-1:])
        rows.append((depth(cam_o, xyz[0]), t.track_id))
    rows.sort()
    if not rows or rows[0][1] != track.track_id:
        return False
    return len(rows) == 1 or rows[1][0] - rows[0][0] >= state.config.marker_diameter_m

