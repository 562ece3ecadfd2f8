"""The two-camera tracker's numbering of a track on the epipolar line of a marker the other
camera numbers, when no recent 3D point of that marker bounds the depth along the line: the
pair's 3D point must be where the bed has carried that marker, and nearer there than any other
marker this camera does not hold.

A marker covered in one camera from the start (side marker 1 of a seed-91 render: the side
view never saw it, the front numbered it at the grid fit) comes out later in that camera as a
new track. Its spot lies 0.2-2.6 px from the line of the front's marker and 8-12 px from any
other, but :func:`~dempath_recon.tracking.numbering.pick` could not check its depth: the marker
was never triangulated, and its grid point bounds the depth only within ``MAX_DEPTH_AGE_S`` of
the fit (after that ``max_speed_m_s`` lets it be anywhere along the line). So the track stayed
unnumbered while the front numbered the marker (four frames there; the largest class of
found-unnumbered points where the other camera numbers the marker, session 18: 96 camera
frames on eight tuning looks).

Here the depth is checked the way the pair numbering checks a marker back in both cameras
(:func:`~dempath_recon.tracking.pair_numbering.only_marker`): every marker this camera does
not hold now is placed where the bed has carried it since its last 3D point (or its fitted
grid point: moved as its nearest tracked neighbours moved), and the pair's point must be the
candidate's carried point's, with every other such marker ``PAIR_RATIO`` times as far. A
marker that cannot be placed could be anywhere: then nothing is numbered.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import on_epipolar_line, triangulate_pairs
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.numbering import LineCandidates
from dempath_recon.tracking.pair_numbering import only_marker
from dempath_recon.tracking.state import StereoState, retire

FloatArray = NDArray[np.float64]


def number_by_carried_pair(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                           markers: NDArray[np.int32], uv: FloatArray, stamp_s: float,
                           events: list[str]) -> NDArray[np.int32]:
    """Number an unnumbered track of ``camera`` as the one marker the other camera numbers
    now whose epipolar line passes it (and no other unnumbered spot of this frame), when the
    pair's 3D point is where the bed has carried that marker and no other marker this
    camera does not hold can be there (see the module). The candidate must not have been
    seen by this camera since the track started, nor refused to it. Numbers given here are
    taken back if a later pair contradicts them
    (:func:`~dempath_recon.tracking.pair_checks.verify`)."""
    todo = np.flatnonzero(markers == UNNUMBERED)
    if not len(todo):
        return markers
    other = state.other(camera)
    held = {int(m) for m in markers if m >= 0}
    lines = LineCandidates.of(state, camera, uv, todo, held, stamp_s)
    if not lines.recent:
        return markers
    cam, cam_o = state.cameras[camera], state.cameras[other]
    everyone = set(state.grid_uv.get(camera, {})) | set(state.grid_uv.get(other, {}))
    out = markers.copy()
    for k in todo:
        tid = int(track_ids[k])
        cands = lines.for_track(state, camera, tid, held)
        close = on_epipolar_line(cam, cam_o, uv[k], cands, state.config.epipolar_px)
        if len(close) != 1:
            continue
        m = close[0]
        xyz, _ = triangulate_pairs(cam, cam_o, uv[k][None], cands[m][None])
        missing = [m, *sorted(n for n in everyone - held - {m} if n not in lines.recent)]
        if only_marker(state, xyz[0], stamp_s, missing) != m:
            continue
        retire(state, camera, m)
        state.trackers[camera].number(tid, m)
        state.late_numbered[camera].add(tid)
        state.counts[camera].numbered_by_epipolar += 1
        events.append(f'{camera}: track {tid} numbered marker {m}: on its epipolar line, '
                      'where the bed has carried it')
        out[k] = m
        held.add(m)
    return out
