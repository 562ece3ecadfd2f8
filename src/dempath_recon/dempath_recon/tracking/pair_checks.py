"""The two-camera tracker's checks before anything is given out: every numbered point against
the other camera's point of the same number (epipolar line, and a 3D point the marker can have
reached); a pair that fails is withheld, and the track may lose its number.
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import triangulate_pairs
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.one_camera import alone
from dempath_recon.tracking.state import StereoState

LOG = logging.getLogger('dempath_recon.tracking.stereo')  # the pipeline's logger
FloatArray = NDArray[np.float64]


def verify(state: StereoState, camera: str, track_ids: NDArray[np.int64],
           markers: NDArray[np.int32], uv: FloatArray, stamp_s: float, events: list[str],
           ) -> NDArray[np.int32]:
    """Check every numbered point against the other camera's point of the same number.

    A pair farther than ``3 * epipolar_px`` from the epipolar line, or whose 3D point the
    marker cannot have reached since its last accepted position, is withheld (-1) in this
    frame. The track loses that number for good if it was numbered after the start
    (epipolar line, late grid) or if one of its links since its last passed check landed
    more than ``doubt_link_px`` from the prediction (the 2D linker likely took a neighbour
    for the covered marker); otherwise the other camera is the likelier culprit and the
    point is only withheld. Pairs that pass update the marker's 3D position. (Undoing just
    the bad link instead, the track lost again with its number, was tried: on the bundled
    render it let that number re-attach to a neighbour later, 6 switches.)

    A track re-attached since its last passed check more than ``doubt_link_px`` from where
    it was expected is not given out with its number until the other camera confirms it
    (withheld, counted as ``unconfirmed``): a marker that reappears some way off may be a
    neighbour, and a wrong number is worse than none, unless no other marker this camera
    does not see now could be there at a plausible speed
    (:func:`~dempath_recon.tracking.one_camera.alone`, counted as ``confirmed_alone``).
    (Withholding it only when another marker was last seen near the spot, at any time, was
    tried: on the bundled render the switch it should stop, a side-camera re-attachment 25 px
    off after 0.2 s, stayed.)
    """
    other, markers = state.other(camera), markers.copy()
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    unsure = {k for k in np.flatnonzero(markers >= 0).tolist()
              if int(track_ids[k]) in tracks
              and tracks[int(track_ids[k])].reattach_px > state.config.doubt_link_px}
    partner = partners(state, other, markers, unsure, stamp_s)
    idx = sorted(partner)
    for k in sorted(unsure - set(idx)):
        tid = int(track_ids[k])
        if alone(state, camera, tid, int(markers[k]), uv[k], markers, stamp_s):
            tracks[tid].reattach_px = 0.0
            state.counts[camera].confirmed_alone += 1
            events.append(f'{camera}: marker {markers[k]} re-attached off its prediction '
                          f'kept at {stamp_s:.3f} s: no other marker can be that near')
            continue
        state.counts[camera].unconfirmed += 1
        state.pending[camera][int(markers[k])] = (stamp_s, uv[k])
        events.append(f'{camera}: marker {markers[k]} withheld at {stamp_s:.3f} s: '
                      f're-attached {tracks[int(track_ids[k])].reattach_px:.1f} px from '
                      'its prediction, not yet confirmed by the other camera')
        markers[k] = UNNUMBERED
    xyz, epi = triangulate_pairs(state.cameras[camera], state.cameras[other],
                                 uv[idx], np.array([partner[k] for k in idx]))
    for k, x, d in zip(idx, xyz, epi, strict=True):
        m = int(markers[k])
        dist, allowed = state.positions.distance(m, stamp_s, x)
        # a doubtful re-attachment is confirmed only by the test that numbers a new track
        epi_ok = state.config.epipolar_px if k in unsure else 3 * state.config.epipolar_px
        if d <= epi_ok and dist <= allowed:
            state.positions.accept(m, stamp_s, x)
            state.pending[camera].pop(m, None)
            if int(track_ids[k]) in tracks:
                tracks[int(track_ids[k])].link_px = 0.0
                tracks[int(track_ids[k])].reattach_px = 0.0
            continue
        counts = state.counts[camera]
        counts.withheld += 1
        if d > epi_ok:
            counts.epipolar_conflicts += 1
            why = f'{d:.1f} px off the epipolar line'
        else:
            counts.position_conflicts += 1
            why = f'3D point {1e3 * dist:.0f} mm from its last position (at most ' \
                  f'{1e3 * allowed:.0f} mm)'
        markers[k] = UNNUMBERED
        tid = int(track_ids[k])
        jump = tracks[tid].link_px if tid in tracks else 0.0
        if tid in state.late_numbered[camera] or jump > state.config.doubt_link_px:
            state.late_numbered[camera].discard(tid)
            state.refused[camera].add((tid, m))
            state.trackers[camera].number(tid, UNNUMBERED)
            counts.revoked += 1
            why += '; its number taken back'
        msg = f'{camera}: marker {m} withheld at {stamp_s:.3f} s: {why}'
        events.append(msg)
        LOG.warning(msg)
    return markers


def partners(state: StereoState, other: str, markers: NDArray[np.int32], unsure: set[int],
             stamp_s: float) -> dict[int, FloatArray]:
    """The other camera's point (2,) px of each numbered detection's marker, seen within a
    frame period: its given-out point, or for an unsure re-attachment (index in ``unsure``)
    also its withheld, unconfirmed one (two cameras that both lost a marker re-attach it
    with no given-out point to check against; the pair can confirm both)."""
    out: dict[int, FloatArray] = {}
    for k in np.flatnonzero(markers >= 0).tolist():
        m = int(markers[k])
        sources = (state.latest[other], state.pending[other]) if k in unsure \
            else (state.latest[other],)
        for source in sources:
            hit = source.get(m)
            if hit is not None and abs(hit[0] - stamp_s) <= 1.0 / state.config.fps:
                out[k] = hit[1]
                break
    return out
