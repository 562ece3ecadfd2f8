"""A number elimination took back for a jump, given back once both cameras pair the track.

:func:`~dempath_recon.tracking.grid_elimination.revoke_jumped` takes back, for good, a number
one camera gave by elimination when the track links farther than ``doubt_link_px`` from its
prediction: no pair check watches a marker only one camera sees, so a track that moved onto a
neighbour's spot would keep the wrong number. But a marker the tine starts pushing leaves its
constant-velocity prediction at once while its track stays on it: on a render of hidden seed
125 with the tool driven twice as fast, the side's track of marker 1 (numbered at frame 1)
missed its prediction by 6.1 px at frame 3 while its neighbours moved 1 px; the track stayed
on 1, lost the number, and when the front camera found 1 at frame 4 both cameras' tracks of it
stayed unnumbered for the 10 frames left (the pair rules name a marker by where the bed carried
it, and a pushed marker is not where the sand around it went: 19-42 mm off).

Once the other camera sees the marker, the pair can decide (:func:`number_regained`). The
track takes its number back, and its partner takes it too, when

- the track kept its links since it was numbered (a jump by re-attachment is not undone: the
  spot it took after a loss may be another marker's);
- no running track of either camera holds the number, and neither camera gave it out within
  ``RECENT_S``;
- exactly one unnumbered running track of the other camera, at least ``PAIR_FRAMES`` old, held
  on the track's epipolar line over their last ``PAIR_FRAMES`` frames
  (:func:`~dempath_recon.tracking.held_line.held_together`);
- the pair's 3D point lies within ``REGAIN_GATE_M`` of where the bed carried the marker, and
  every other marker no running track holds is carried at least ``REGAIN_RATIO`` times as far
  (each must be placeable): had the track moved onto a neighbour's spot, the pair would be that
  neighbour, carried nearer.

The numbers so given are late numbers: a contradicting pair check takes them back
(:func:`~dempath_recon.tracking.pair_checks.verify`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import triangulate_pairs
from dempath_recon.tracking.held_line import held_together
from dempath_recon.tracking.linker import Track
from dempath_recon.tracking.release import unbroken
from dempath_recon.tracking.state import RECENT_S, StereoState, carried_point, give_late
from dempath_recon.tracking.track_pairs import PAIR_FRAMES

FloatArray = NDArray[np.float64]
REGAIN_GATE_M = 0.03  # the pair lies this near where the bed carried the marker at most [m]
# (NUMBERED_GATE_M of track_pairs: a pushed marker is carried poorly; 19 mm on the seed-125 look)
REGAIN_RATIO = 1.5  # every other free marker is carried at least this many times as far (the
# track's own history names the marker; the carried places only have to rule out a neighbour:
# 19 mm against 38 mm on the seed-125 look)


def number_regained(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                    markers: NDArray[np.int32], stamp_s: float, events: list[str],
                    ) -> NDArray[np.int32]:
    """``markers`` (k,) of this frame's tracks ``track_ids`` (k,) of ``camera``, with the
    numbers elimination took back for a jump (``state.jumped``, either camera's) given back
    to the track and its partner of the other camera (module docstring)."""
    out = markers
    for cam in sorted(state.jumped):
        for tid, (number, since) in sorted(state.jumped[cam].items()):
            partner = _partner(state, cam, tid, number, since, stamp_s)
            if partner is None:
                continue
            track, other_track = partner
            other = state.other(cam)
            give_late(state, cam, track, number)
            give_late(state, other, other_track, number)
            state.latest[other][number] = (other_track.last_stamp_s, other_track.uv.copy())
            del state.jumped[cam][tid]
            state.counts[cam].numbered_by_regain += 1
            events.append(f'{cam}: track {tid} took back marker {number} with {other} track '
                          f'{other_track.track_id}: on its epipolar line for {PAIR_FRAMES} '
                          'frames, where the bed carried it')
            mine = track.track_id if cam == camera else other_track.track_id
            out = np.where(track_ids == mine, number, out).astype(np.int32)
    return out


def _partner(state: StereoState, camera: str, track_id: int, number: int, since: float,
             stamp_s: float) -> tuple[Track, Track] | None:
    """(the track, its partner of the other camera) when ``number`` may be given back to
    both (module docstring), else None; forgets a track that is gone or numbered again."""
    fps = state.config.fps
    track = next((t for t in state.trackers[camera].tracks if t.track_id == track_id), None)
    if track is None or track.marker >= 0:
        del state.jumped[camera][track_id]
        return None
    if track.lost or abs(track.last_stamp_s - stamp_s) > 1.0 / fps \
            or not unbroken(track, since, fps):
        return None
    held = {t.marker for c in state.cameras for t in state.trackers[c].tracks
            if t.marker >= 0 and not t.lost}
    if number in held or any(number in state.latest[c] and abs(state.latest[c][number][0]
                                                                 - stamp_s) <= RECENT_S
                             for c in state.cameras):
        return None
    other = state.other(camera)
    partners = [p for p in state.trackers[other].tracks
                if not p.lost and p.marker < 0 and len(p.history) >= PAIR_FRAMES
                and abs(p.last_stamp_s - stamp_s) <= 1.0 / fps
                and held_together(state, camera, track, p, PAIR_FRAMES)]
    if len(partners) != 1:
        return None
    at = partners[0].uv + partners[0].velocity * (track.last_stamp_s
                                                  - partners[0].last_stamp_s)
    xyz, _ = triangulate_pairs(state.cameras[camera], state.cameras[other], track.uv[None],
                               at[None])
    return (track, partners[0]) if _carried_there(state, number, xyz[0], stamp_s, held) \
        else None


def _carried_there(state: StereoState, number: int, xyz: FloatArray, stamp_s: float,
                   held: set[int]) -> bool:
    """Whether the pair's 3D point ``xyz`` (3,) m lies within ``REGAIN_GATE_M`` of where the
    bed carried ``number`` and every other marker no running track holds is carried at least
    ``REGAIN_RATIO`` times as far (False when any of them cannot be placed)."""
    dist = {}
    for m in state.config.grid.points()[0].tolist():
        if m in held:
            continue
        placed = carried_point(state, m, stamp_s)
        if placed is None:
            return False
        dist[m] = float(np.linalg.norm(xyz - placed[0]))
    own = dist.get(number, np.inf)
    return own <= REGAIN_GATE_M and all(d >= REGAIN_RATIO * own for m, d in dist.items()
                                        if m != number)
