"""A marker coming out of the sand mid-pass in one camera only, numbered where the bed has
carried it.

A marker covered at the grid fit and uncovered later in one camera, while the other camera
does not show it, has nothing to number it: the epipolar line and the pair rules need the other
camera, the late grid rule (``one_camera.late_grid``) wants it at its fitted grid point, which
the bed has carried it away from by then, and elimination
(:mod:`~dempath_recon.tracking.grid_elimination`) takes only tracks born at the fit. On five
tuning renders the side's marker 2 came out at frame 8-9 of 17 and stayed unnumbered to the
end (about 40 marker-frames), though at its first frame its spot lay 3-4 px from where its
neighbours' motion had carried its grid point (``state.carried_point``, projected) and the next
such point 27-29 px away.

So a track decides at its birth (its first ``BIRTH_FRAMES`` frames, kept links), born after the
grid fit's window (elimination's before), when

- the marker whose carried point, projected into this camera, lies nearest its spot is one no
  track of either camera holds (running or lost) and the other camera does not give out now,
  within ``grid_gate_px``;
- every other marker not seen on a spot of its own in this camera's frame (a number held by a
  doubtful re-attachment counts as not seen: ``state.sure_numbers``) is carried at least
  ``SECOND_RATIO`` times as far, and none cannot be placed;
- no marker this camera saw before and does not surely hold now could have reached the spot
  from its last sighting nearly as easily as the marker from its fitted grid point
  (``one_camera.lost_nearby``: a lost marker coming back beside a covered one's place is
  its own);
- no unnumbered spot of the other camera's latest frame lies on its epipolar line, nor a marker
  the other camera gives out and this one holds no track of (the pair rules decide those);
- no other spot of the frame lies within ``TOUCH_DIAMETERS`` marker diameters (two touching
  markers, whose tracks the 2D link may have swapped);
- no other new track of this frame claims the same marker.

The number is watched as elimination's are (``state.eliminated``: taken back for good when the
track jumps or its spot may hold a neighbour, until a pair check passes). Off by default
(``StereoTrackConfig.coming_out``): the looks held apart when it was built did not gain.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import marker_diameter_px, project
from dempath_recon.tracking.grid_elimination import (
    SECOND_RATIO,
    START_WINDOW_S,
    other_decides,
)
from dempath_recon.tracking.linker import Track
from dempath_recon.tracking.one_camera import lost_nearby
from dempath_recon.tracking.state import (
    RECENT_S,
    StereoState,
    carried_point,
    sure_numbers,
)

FloatArray = NDArray[np.float64]
TOUCH_DIAMETERS = 1.0  # a new spot with another spot this many marker diameters away waits (on
# a fast-tool render the front's new spot of 8, 4 px from 7's, took 7 while 8's track held 7's)
BIRTH_FRAMES = 2  # a track decides in its first frames only: the carried point of a marker no
# camera sees drifts from it by a few px a frame (on a tuning render 3 px at birth, 15 px 4
# frames later, when a neighbour's was nearer)


def number_coming_out(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                      markers: NDArray[np.int32], uv: FloatArray, stamp_s: float,
                      events: list[str]) -> NDArray[np.int32]:
    """``markers`` (k,) with the new tracks of ``camera`` that are a marker coming out of the
    sand in this camera only numbered by where the bed carried it (module docstring); ``uv``
    (k, 2) px are the frame's points of ``track_ids`` (k,)."""
    other = state.other(camera)
    if camera not in state.grid_uv or not (markers < 0).any() \
            or state.last_stamp[other] is None or state.provisional & {camera, other}:
        return markers
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    new = [k for k in np.flatnonzero(markers < 0).tolist() if _newborn(state, camera,
                                                                        tracks.get(int(track_ids[k])))]
    if not new:
        return markers
    sure = sure_numbers(state, camera, track_ids, markers)
    seen = {int(m) for m in sure if m >= 0}
    held = {t.marker for c in state.cameras for t in state.trackers[c].tracks if t.marker >= 0}
    given_o = {m for m, (t, _) in state.latest[other].items() if abs(t - stamp_s) <= RECENT_S}
    placed = _placed(state, camera, [m for m in state.config.grid.points()[0].tolist()
                                     if m not in seen], stamp_s)
    if placed is None:
        return markers
    size = marker_diameter_px(state.cameras[camera], state.config.grid,
                              state.config.marker_diameter_m)
    claims: dict[int, list[int]] = {}
    for k in new:
        if _touching(uv, k, TOUCH_DIAMETERS * size):
            continue
        m = _nearest_free(state, placed, uv[k], held | given_o)
        if m is not None and (int(track_ids[k]), m) not in state.refused[camera] \
                and lost_nearby(state, camera, m, uv[k], sure, stamp_s) is None:
            claims.setdefault(m, []).append(k)
    out = markers.copy()
    for m, rows in claims.items():
        if len(rows) != 1 or other_decides(state, camera, uv[rows[0]], stamp_s):
            continue
        tid = int(track_ids[rows[0]])
        state.trackers[camera].number(tid, m)
        state.late_numbered[camera].add(tid)
        state.eliminated[camera][tid] = (stamp_s, tracks[tid].link_px)
        state.counts[camera].numbered_by_carried += 1
        out[rows[0]] = m
        events.append(f'{camera}: track {tid} numbered marker {m}: new where the bed carried '
                      'it, a marker no camera holds')
    return out


def _touching(uv: FloatArray, k: int, reach_px: float) -> bool:
    """Whether another of the frame's points ``uv`` (n, 2) px lies within ``reach_px`` of
    point ``k``: two touching markers, whose tracks the 2D link may have swapped."""
    d = np.linalg.norm(uv - uv[k], axis=1)
    d[k] = np.inf
    return bool((d < reach_px).any())


def _newborn(state: StereoState, camera: str, track: Track | None) -> bool:
    """Whether ``track`` is in its first ``BIRTH_FRAMES`` frames, born after the grid fit's
    window (elimination decides those), unnumbered and never re-attached."""
    return track is not None and track.marker < 0 and track.reattached is None \
        and 0 < len(track.history) <= BIRTH_FRAMES \
        and track.history[0][0] > state.grid_time.get(camera, 0.0) + START_WINDOW_S


def _placed(state: StereoState, camera: str, numbers: list[int], stamp_s: float,
            ) -> dict[int, FloatArray] | None:
    """Marker -> (2,) px: where the bed has carried each of ``numbers``, projected into
    ``camera``; None when any cannot be placed (it could be anywhere)."""
    out = {}
    cam = state.cameras[camera]
    for m in numbers:
        at = carried_point(state, m, stamp_s)
        if at is None:
            return None
        out[m] = project(cam, at[0][None])[0]
    return out


def _nearest_free(state: StereoState, placed: dict[int, FloatArray], point: FloatArray,
                  taken: set[int]) -> int | None:
    """The marker carried nearest ``point`` (2,) px when it is not in ``taken``, within
    ``grid_gate_px``, and every other placed marker is ``SECOND_RATIO`` times as far."""
    if not placed:
        return None
    ranked = sorted((float(np.linalg.norm(p - point)), m) for m, p in placed.items())
    near, m = ranked[0]
    if m in taken or near > state.config.grid_gate_px \
            or (len(ranked) > 1 and ranked[1][0] < SECOND_RATIO * near):
        return None
    return m
