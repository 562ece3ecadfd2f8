"""The two-camera tracker's checks on one camera's evidence: where a marker this camera never
saw can appear (its fitted grid point), and whether a re-attached spot can be any other marker.

Used when the other camera has nothing to check against: a marker covered at the start that
appears at its grid point (:func:`late_grid`), a never-triangulated marker's grid point as the
depth along an epipolar line (:func:`grid_anchor`), and a re-attachment far from its prediction
that no other marker could have reached at a plausible speed (:func:`alone`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import epipolar_distance
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.state import (
    ALONE_RATIO,
    MAX_DEPTH_AGE_S,
    MIN_SPEED_PX_S,
    RECENT_S,
    StereoState,
    grid_xyz,
)

FloatArray = NDArray[np.float64]


def late_grid(state: StereoState, camera: str, uv: FloatArray, k: int, seen: set[int],
              ) -> int:
    """A marker this camera never saw, appearing as a new track alone and unambiguously at
    its fitted grid point (it was covered at the start): its number, else -1."""
    grid = state.grid_uv.get(camera, {})
    gate = state.config.grid_gate_px
    free = [m for m in grid if m not in seen and m not in state.latest[camera]]
    near = [m for m in free if np.linalg.norm(uv[k] - grid[m]) < gate]
    if len(near) != 1:
        return UNNUMBERED
    d = np.linalg.norm(uv[k] - grid[near[0]])
    if any(np.linalg.norm(uv[k] - grid[m]) < d + gate / 2 for m in grid if m != near[0]):
        return UNNUMBERED  # another grid point almost as near: unsure
    others = np.delete(uv, k, axis=0)
    if len(others) and (np.linalg.norm(others - grid[near[0]], axis=1) < gate).any():
        return UNNUMBERED  # two spots at one grid point: say nothing
    return near[0]


def grid_anchor(state: StereoState, camera: str, marker: int, stamp_s: float,
                ) -> tuple[FloatArray, float] | None:
    """Where a marker never triangulated can be: ``(point (3,) m, allowed distance m)``.

    Its fitted grid point in ``camera`` (the projected grid shifted onto the detections)
    placed at the grid point's depth, with the grid gate at that depth as extra allowance
    besides the usual ``position_gate_m + max_speed_m_s * dt``; only within
    ``MAX_DEPTH_AGE_S`` of the frame the grid was fitted on, and only for a marker this
    camera has not seen (its own sightings would be the better anchor, but they carry no
    depth). None otherwise.
    """
    t0 = state.grid_time.get(camera)
    if t0 is None or stamp_s - t0 > MAX_DEPTH_AGE_S or marker in state.latest[camera]:
        return None
    placed = grid_xyz(state, camera, marker)
    if placed is None:
        return None
    z, point = placed
    allowed = (state.config.position_gate_m
               + state.config.grid_gate_px * z / float(state.cameras[camera].K[0, 0])
               + state.config.max_speed_m_s * (stamp_s - t0))
    return point, allowed


def alone(state: StereoState, camera: str, track_id: int, marker: int, uv: FloatArray,
          markers: NDArray[np.int32], stamp_s: float) -> bool:
    """Whether no other marker can plausibly be at a re-attached spot (one camera's check).

    The track's own marker needs the speed (in this camera) from its last sighting before
    its latest re-attachment to the spot over the time since; every other marker not
    numbered on another spot of this frame (a rival) would need the speed from its own
    last sighting in this camera (never seen here: its fitted grid point when the grid was
    fitted) over its own time since. The spot is the track's marker when each rival would
    need at least ``ALONE_RATIO`` times the own speed (at least ``MIN_SPEED_PX_S``), or
    when the other camera sees the rival now off this spot's epipolar line (more than
    ``3 * epipolar_px``). A marker this camera has no position for at all is a rival
    anywhere (the spot stays withheld).
    Speeds rather than distances: a rival unseen for longer may have moved farther.
    """
    track = next(t for t in state.trackers[camera].tracks if t.track_id == track_id)
    gaps = [i for i in range(len(track.history) - 1)
            if track.history[i + 1][0] - track.history[i][0] > 1.5 / state.config.fps]
    if not gaps:
        return False
    own = track.history[gaps[-1]]  # its last sighting before the latest re-attachment
    own_speed = float(np.hypot(uv[0] - own[1], uv[1] - own[2])) / max(stamp_s - own[0],
                                                                      1e-3)
    taken = {int(m) for m in markers if m >= 0}
    other = state.other(camera)
    for m in state.config.grid.points()[0].tolist():
        if m == marker or m in taken:
            continue
        seen = state.latest[camera].get(m)
        if seen is None and m in state.grid_uv.get(camera, {}):
            seen = (state.grid_time[camera], state.grid_uv[camera][m])
        if seen is None:
            return False  # a marker with nothing to place it: could be anywhere
        speed = float(np.linalg.norm(uv - seen[1])) / max(stamp_s - seen[0], 1e-3)
        if speed > ALONE_RATIO * max(own_speed, MIN_SPEED_PX_S):
            continue
        now = state.latest[other].get(m)
        if now is not None and abs(now[0] - stamp_s) <= RECENT_S and epipolar_distance(
                state.cameras[camera], state.cameras[other], uv[None], now[1][None]
                )[0, 0] > 3 * state.config.epipolar_px:
            continue
        return False
    return True


def lost_nearby(state: StereoState, camera: str, marker: int, uv: FloatArray,
                markers: NDArray[np.int32], stamp_s: float) -> int | None:
    """A marker this camera saw before and does not surely hold in this frame (``markers``,
    see :func:`~dempath_recon.tracking.state.sure_numbers`) that could have reached a new
    spot ``uv`` (2,) px nearly as easily as ``marker`` from its fitted grid point: it needs
    less than ``ALONE_RATIO`` times the speed (px/s, at least ``MIN_SPEED_PX_S``) from its
    last sighting; None if there is none. The grid point is where a covered marker was at
    the fit, not where the sand has carried it since (on a tuning render the side lost
    marker 1, its track re-attached 13 px away onto another spot, and 1 appeared 11 px from
    its last sighting at 2's grid point: numbered 2 for the rest of the pass)."""
    grid = state.grid_uv.get(camera, {})
    if marker not in grid:
        return None
    own = float(np.linalg.norm(uv - grid[marker])) / max(stamp_s - state.grid_time[camera],
                                                          1e-3)
    held = {int(m) for m in markers if m >= 0}
    for m, (t, p) in sorted(state.latest[camera].items()):
        if m == marker or m in held or t >= stamp_s:
            continue
        speed = float(np.linalg.norm(uv - p)) / max(stamp_s - t, 1e-3)
        if speed <= ALONE_RATIO * max(own, MIN_SPEED_PX_S):
            return int(m)
    return None
