"""Whether a spot of the other camera on a track's epipolar line can be the track's marker.

Elimination (:mod:`~dempath_recon.tracking.grid_elimination`) numbers a track only one camera
sees by the free grid point it started at, and leaves it to the pair rules when an unnumbered
spot of the other camera lies on its epipolar line, or a marker the other camera gives out (and
this one holds no track of) lies near that line: that spot may be the same marker, and a pair
decides better than one camera. But an epipolar line crosses the whole bed; on an oblique view
it passes near several markers, and the spot on it is often another marker, one the pair rules
cannot name with this track either. Then nothing numbers the track for the whole pass. On the
ten long-pass tuning looks of session 21 (main 679d130) this kept tracks of ``t113_asis``
(front 11 for 9 frames, front 12 for 6, side 2 for 11) and of ``t111_dusk`` (side 10 for 12,
front 14 for 11) unnumbered from their first frame: of 3,986 marker-frames at least half
visible, 210 were found but never numbered, 146 of them while the other camera did not give
the marker out.

A spot on the line is the track's marker only when their pair lies where a marker can be: near
where the bed carried it (:func:`~dempath_recon.tracking.state.carried_point`). So the
deferral is kept only when

- the pair with an unnumbered spot on the line lies within ``RIVAL_GATE_M`` of the carried
  place of some marker no track of either camera holds and neither camera has given out, or
  within ``position_gate_m`` of any other marker's (:func:`may_be_free`: the spot may be that
  marker, the track's own or another), or
- the pair with a marker the other camera gives out lies within ``RIVAL_GATE_M`` of where the
  bed carried that marker (:func:`may_be_given`: the spot may be it, coming out of the sand);

a marker that cannot be placed counts as near (unnumbered is better than wrong). Otherwise the
spot is a marker this track is not, and elimination's own guards decide (one free grid point
near the track's start, twice as near as the next, every other near one seen on its own spot,
no rival claim, the number watched for jumps), with one more: when only this module let the
track through, each neighbour elimination counts as seen on its own spot must be given out by a
track whose number is settled, not a late one on probation (:func:`neighbours_settled`). On
``s87_roll_glare`` (hidden seed 87, camera roll, glare) the front's spot of 14 took 15 by the
pair numbering a frame before, so 15 looked seen and elimination gave 14 to the spot of 15:
switches 50 -> 85 and wrong-pair points 18 -> 25 without this guard, unchanged with it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import epipolar_distance, triangulate_pairs
from dempath_recon.tracking.state import StereoState, carried_point

FloatArray = NDArray[np.float64]
RIVAL_GATE_M = 0.02  # a pair this near a marker's carried place may be that marker [m] (a
# marker the bed moved before the first frame lies 5-10 mm from its grid point; on the long
# tuning looks the unnumbered spots the rule let through paired 25-55 mm from every free
# marker's place, those it kept deferring 4.5-17 mm with the gate at 30 mm; at 30 mm
# ``t111_dusk`` gained nothing (25-27 mm), at 15 and 20 mm the same)


def may_be_free(state: StereoState, camera: str, point: FloatArray, uv_other: FloatArray,
                stamp_s: float) -> bool:
    """Whether any of the other camera's spots ``uv_other`` (k, 2) px on the epipolar line of
    ``camera``'s spot ``point`` (2,) px (within ``epipolar_px``) pairs with it to a 3D point
    within ``RIVAL_GATE_M`` of the carried place of a marker nobody holds at ``stamp_s`` [s],
    or within ``position_gate_m`` of any other marker's (module docstring); a free marker that
    cannot be placed counts as near (refuse when unsure)."""
    other = state.other(camera)
    uv_other = np.asarray(uv_other, np.float64).reshape(-1, 2)
    if not len(uv_other):
        return False
    d = epipolar_distance(state.cameras[camera], state.cameras[other], point[None], uv_other)[0]
    on = uv_other[d <= state.config.epipolar_px]
    if not len(on):
        return False
    placed = marker_places(state, camera, stamp_s)
    if placed is None:
        return True
    places, gates = placed
    if not len(places):
        return False
    xyz, _ = triangulate_pairs(state.cameras[camera], state.cameras[other],
                               np.repeat(np.asarray(point, np.float64)[None], len(on), 0), on)
    gaps = np.linalg.norm(xyz[:, None] - places[None], axis=2)
    return bool((gaps <= gates[None]).any())


def may_be_given(state: StereoState, camera: str, point: FloatArray,
                 given: dict[int, FloatArray], gate_px: float, stamp_s: float) -> bool:
    """Whether any marker the other camera gives out (``given``: number -> (2,) px, markers
    ``camera`` holds no track of) lies within ``gate_px`` of the epipolar line of ``camera``'s
    spot ``point`` (2,) px and pairs with it within ``RIVAL_GATE_M`` of where the bed carried
    that marker by ``stamp_s`` [s] (the spot may be it, coming out of the sand); a marker that
    cannot be placed counts as near."""
    if not given:
        return False
    other = state.other(camera)
    numbers = list(given)
    uv_other = np.array([given[m] for m in numbers], np.float64).reshape(-1, 2)
    d = epipolar_distance(state.cameras[camera], state.cameras[other], point[None], uv_other)[0]
    for i in np.flatnonzero(d <= gate_px).tolist():
        at = carried_point(state, numbers[i], stamp_s)
        if at is None:
            return True
        xyz, _ = triangulate_pairs(state.cameras[camera], state.cameras[other],
                                   np.asarray(point, np.float64)[None], uv_other[i][None])
        if float(np.linalg.norm(xyz[0] - at[0])) <= RIVAL_GATE_M:
            return True
    return False


def neighbours_settled(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                       markers: NDArray[np.int32], neighbours: list[int]) -> bool:
    """Whether each marker of ``neighbours`` is given out in this frame of ``camera``
    (``markers`` (k,) of the tracks ``track_ids`` (k,)) by tracks whose number is settled: not
    a late number still on probation (``state.late_numbered``: a later contradicting pair takes
    it back). Elimination counts a neighbour seen on its own spot as not this track's marker;
    when only this module let the track through, a neighbour's fresh pair number may be the
    mistake (on a seed-87 look the front's spot of 14 took 15 by the pair numbering one frame
    before, so elimination gave 14 to the spot of 15)."""
    late = state.late_numbered[camera]
    for n in neighbours:
        rows = np.flatnonzero(markers == n)
        if not len(rows) or any(int(track_ids[r]) in late for r in rows.tolist()):
            return False
    return True


def marker_places(state: StereoState, camera: str, stamp_s: float,
                  ) -> tuple[FloatArray, FloatArray] | None:
    """``((n, 3) m, (n,) m)``: where the bed carried each marker of ``camera``'s grid by
    ``stamp_s`` [s], and the gate a pair must lie within to be that marker: ``RIVAL_GATE_M``
    for a marker no track of either camera holds and neither camera has given out (placed
    from its grid point, or from a 3D point long ago), ``position_gate_m`` for the others
    (placed from their own recent 3D points; a held marker that cannot be placed is left out).
    None when a free marker cannot be placed."""
    held = {t.marker for c in state.cameras for t in state.trackers[c].tracks if t.marker >= 0}
    given = {m for c in state.cameras for m in state.latest[c]}
    places, gates = [], []
    for m in state.grid_uv.get(camera, {}):
        free = m not in held and m not in given
        at = carried_point(state, m, stamp_s)
        if at is None:
            if free:
                return None
            continue
        places.append(at[0])
        gates.append(RIVAL_GATE_M if free else state.config.position_gate_m)
    return np.array(places, np.float64).reshape(-1, 3), np.array(gates, np.float64)
