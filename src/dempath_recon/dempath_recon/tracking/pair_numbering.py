"""The two-camera tracker's numbering of a marker back in both cameras while neither has it
numbered: an unnumbered track of each camera, each on the other's epipolar line, takes the number
of the one missing marker the bed has carried to their 3D point.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import epipolar_distance, triangulate_pairs
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.state import (
    CARRY_FLOOR_M,
    RECENT_S,
    StereoState,
    carried_point,
    retire,
    sure_numbers,
    unnumbered_tracks,
)

FloatArray = NDArray[np.float64]
PAIR_RATIO = 2.5  # a pair is numbered as the nearest missing marker when every other is this
# many times as far from where the bed carried it (3 left the bundled render re-encoded once
# with marker 8 unnumbered for 7 frames at 13 mm against 9's 34-38 mm; 2.5 numbers it, no
# switch on the 15 variations, the bundled render unchanged)


def number_pairs(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                 markers: NDArray[np.int32], uv: FloatArray, stamp_s: float,
                 events: list[str]) -> NDArray[np.int32]:
    """Number an unnumbered track of each camera together, as the one missing marker
    their pair can be.

    A marker that comes back in both cameras while neither has it numbered cannot be
    numbered by the other camera's line (each waits for the other). Here an unnumbered
    track of this camera and one of the other camera's last frame (at most one frame
    period old) are a pair when each is the other's only unnumbered point within
    ``epipolar_px`` of its epipolar line; the pair's 3D point is given the number of the
    marker, among those numbered in neither camera now, that :func:`only_marker` finds (a
    track re-attached far off and not confirmed since does not hold its number here:
    :func:`~dempath_recon.tracking.state.sure_numbers`; on a tuning render the side's track
    of a lost marker 1 took another spot, 1 came back in both cameras beside 2's grid point,
    and the pair took 2).
    A track of either camera the grid fit left unsure (``state.grid_unsure``: an unnumbered
    spot of the other camera lay on its line, so the pair was unsure) is not paired here:
    its own rule (:func:`~dempath_recon.tracking.numbering.number_grid_unsure`) waits for
    the line to clear.
    A point of this camera on the epipolar line of a marker the other camera has numbered
    now, and that this camera does not surely hold elsewhere, is not paired
    (:func:`_on_numbered_lines`). Both tracks take the number (and lose
    it if a later pair check contradicts it), and the other camera's point becomes its
    latest, so ``verify`` checks the pair and records the 3D point at once.
    """
    other = state.other(camera)
    free = state.free[other]
    if free is None or abs(free[0] - stamp_s) > 1.0 / state.config.fps or not len(free[1]):
        return markers
    t_o, o_ids, o_uv = free
    o_numbered = {t.track_id for t in state.trackers[other].tracks if t.marker >= 0}
    waiting_o = state.grid_unsure.get(other, {})
    keep = [j for j, tid in enumerate(o_ids.tolist())
            if tid not in o_numbered and tid not in waiting_o]
    waiting = state.grid_unsure.get(camera, {})
    mine = np.flatnonzero(unnumbered_tracks(state, camera, track_ids, markers)
                          & ~np.isin(track_ids, list(waiting)))
    if not keep or not len(mine):
        return markers
    cam, cam_o = state.cameras[camera], state.cameras[other]
    close = epipolar_distance(cam, cam_o, uv[mine], o_uv[keep]) <= state.config.epipolar_px
    held = {int(m) for m in sure_numbers(state, camera, track_ids, markers) if m >= 0}
    taken = held | {m for m, (t, _) in state.latest[other].items() if abs(t - stamp_s) <= RECENT_S}
    missing = [m for m in state.config.grid.points()[0].tolist() if m not in taken]
    claimed = _on_numbered_lines(state, camera, uv[mine], stamp_s, held)
    claimed_o = _on_own_lines(state, camera, markers, uv, o_uv[keep])
    markers = markers.copy()
    for a, k in enumerate(mine.tolist()):
        js = np.flatnonzero(close[a])
        if len(js) != 1 or close[:, js[0]].sum() != 1 or claimed[a] or claimed_o[js[0]]:
            continue
        j = keep[int(js[0])]
        tid, tid_o = int(track_ids[k]), int(o_ids[j])
        xyz, _ = triangulate_pairs(cam, cam_o, uv[k][None], o_uv[j][None])
        number = only_marker(state, xyz[0], stamp_s, missing)
        if number < 0 or (tid, number) in state.refused[camera] \
                or (tid_o, number) in state.refused[other]:
            continue
        for c, t in ((camera, tid), (other, tid_o)):
            retire(state, c, number)
            state.trackers[c].number(t, number)
            state.late_numbered[c].add(t)
        state.latest[other][number] = (t_o, o_uv[j])
        state.counts[camera].numbered_by_pair += 1
        events.append(f'{camera}: track {tid} and {other} track {tid_o} numbered marker '
                      f'{number} as a pair: no other missing marker can be there')
        markers[k] = number
        missing.remove(number)
    return markers


def _on_numbered_lines(state: StereoState, camera: str, uv: FloatArray, stamp_s: float,
                       held: set[int]) -> NDArray[np.bool_]:
    """(n,) whether each point ``uv`` (n, 2) px lies within ``epipolar_px`` of the line of a
    point the other camera gave out numbered within ``RECENT_S``, of a marker not in ``held``
    (the markers this camera surely holds on its tracks now): it may be that marker, back
    in this camera, and a pair with one of the other camera's unnumbered points would be a
    wrong correspondence (on a tuning render marker 5's spot in the side camera and marker
    9's in the front, both unnumbered, paired and took 9's number while the front had 5).
    A marker this camera holds on another spot is not back here, and its line says nothing:
    counted, it kept a spot of both cameras unnumbered for the whole pass on a seed-21 render
    (marker 10 on the line of 14, which each camera tracked beside it, 28 marker-frames)."""
    other = state.other(camera)
    seen = [p for m, (t, p) in state.latest[other].items()
            if abs(t - stamp_s) <= RECENT_S and m not in held]
    if not seen or not len(uv):
        return np.zeros(len(uv), bool)
    d = epipolar_distance(state.cameras[other], state.cameras[camera], np.array(seen), uv)
    return np.asarray((d <= state.config.epipolar_px).any(axis=0), bool)


def _on_own_lines(state: StereoState, camera: str, markers: NDArray[np.int32], uv: FloatArray,
                  uv_o: FloatArray) -> NDArray[np.bool_]:
    """(k,) whether each unnumbered point ``uv_o`` (k, 2) px of the other camera lies within
    ``epipolar_px`` of the line of a point this frame gives out numbered (``markers``,
    ``uv`` (n, 2) px) with a marker the other camera saw hidden behind another at the grid
    fit (``state.fit_merged``) and holds on none of its running tracks: it may be that marker,
    out from behind, and not this camera's unnumbered spot's (:func:`_on_numbered_lines`
    seen from the other side: on a tuning render the side's new spot of marker 5, hidden
    behind 10 at the fit, on the line of the front's 5, paired with the front's spot of 9
    and took 9). Markers the other camera never saw hidden do not count: counted, the lines
    of markers the side does not see kept right pairs of the side's unnumbered spots
    unnumbered on two tuning renders (84.3 -> 75.0 % and 93.8 -> 91.2 % numbered right)."""
    other = state.other(camera)
    hidden = set().union(*state.fit_merged[other].values()) - {
        t.marker for t in state.trackers[other].tracks if t.marker >= 0 and not t.lost}
    lines = [k for k, m in enumerate(markers.tolist()) if m in hidden]
    if not lines or not len(uv_o):
        return np.zeros(len(uv_o), bool)
    d = epipolar_distance(state.cameras[camera], state.cameras[other], uv[lines], uv_o)
    return np.asarray((d <= state.config.epipolar_px).any(axis=0), bool)


def only_marker(state: StereoState, xyz: FloatArray, stamp_s: float, missing: list[int],
                ) -> int:
    """The one marker of ``missing`` that a 3D point can be, else -1.

    Each missing marker is placed where the bed has carried it since its last accepted 3D
    position (``MarkerPositions.carried``: moved as its nearest tracked neighbours moved; a
    marker never triangulated starts from its fitted grid point when the grid was fitted). The
    point is the nearest such marker's when it lies within what the marker can have reached
    (``position_gate_m + max_speed_m_s x dt``) and every other missing marker is at least
    ``PAIR_RATIO`` times as far (at least ``CARRY_FLOOR_M``). A missing marker that cannot be
    placed (no position, or no neighbour tracked across its gap) could be anywhere (-1). Its
    last position alone is not enough: the bed carries a covered marker 50 mm in half a second,
    to where a neighbour was lost shortly before (measured on the bundled render: marker 8 back
    13 mm from 9's last point, 50 mm from its own; carried, 4.5 mm from 8 and 25 mm from 9).
    """
    ages = []
    for m in missing:
        placed = carried_point(state, m, stamp_s)
        if placed is None:
            return UNNUMBERED
        at, since = placed
        reach = state.config.position_gate_m + state.config.max_speed_m_s * (stamp_s - since)
        dist = float(np.linalg.norm(xyz - at))
        ages.append((dist, dist <= reach, m))
    ages.sort()
    if not ages or not ages[0][1]:
        return UNNUMBERED
    bar = PAIR_RATIO * max(ages[0][0], CARRY_FLOOR_M)
    if len(ages) > 1 and ages[1][0] < bar:
        return UNNUMBERED
    return ages[0][2]

