"""A numbered track whose two-marker spot parts gives its number back.

Two touching markers can show as one spot for a while (the detector's split could not part
them, or they lie on one line of sight; the detector flags such a spot ``crowded``: wider than
one marker) and a track, numbered on that spot, follows its centre, which lies between the two
markers. When the spot parts (the detector's split parts the blob: ``Detections.parted``), the
track links to whichever part lies nearer its prediction, and which marker that is, the spot's
history cannot say. On a tuning re-render (seed 6, the front camera) the track of a spot holding
markers 9 and 10, numbered 9 at the grid fit, took 10's part when the split first parted them and
kept 9 (a wrong number in 2D; marker 9's part started a new track).

The rule: a numbered track that was linked last frame to a crowded spot and is linked now to a
part of a split blob with another part within ``SIBLING_DIAMETERS`` marker diameters of it loses
its number for good (refused, as a check's revocation), so the numbering may number the parts
afresh, each by its own evidence; its point is not given out with that number.

Measured on the tuning re-renders (session 17, track15; with the cut-disc split): the seed-6 look
went 65.0 -> 75.4 % numbered right, 10 -> 4 switches, 4 -> 1 wrong-pair 3D points; pooled over 26
looks 77.7 -> 77.6 % (numbers given back and not given again), 66 -> 60 switches, 17 -> 14 wrong
pairs. Not kept: the same for any track whose spot was not a part last frame (parts come and
go from frame to frame, and the numbers given back were numbers lost: 77.7 -> 73.8 %, and on a
dusk look 1 -> 12 switches).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.detect import Detections, own_detections
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.state import StereoState, take_back

FloatArray = NDArray[np.float64]
SIBLING_DIAMETERS = 1.5  # parts of one split blob lie closer than this many diameters


def flagged(det: Detections, flags: NDArray[np.bool_] | None,
            uv: FloatArray) -> NDArray[np.bool_]:
    """(k,) whether each of the frame's points ``uv`` (k, 2) [px] is one of ``det``'s spots
    whose flag (``flags``: ``det.parted`` or ``det.crowded``, or None: none) is set (each point
    is one of ``det``'s)."""
    if flags is None or not flags.any():
        return np.zeros(len(uv), np.bool_)
    own = own_detections(det.uv, uv)
    return np.asarray((own >= 0) & flags[np.maximum(own, 0)], np.bool_)


def revoke_at_parting(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                      markers: NDArray[np.int32], uv: FloatArray, det: Detections,
                      was_crowded: set[int], stamp_s: float, diameter_px: float,
                      events: list[str]) -> NDArray[np.int32]:
    """``markers`` with the numbers of tracks whose spot just parted taken back.

    Args:
        state: the tracker's state (its linkers and refusals are updated).
        camera: this frame's camera.
        track_ids: (k,) the frame's tracks.
        markers: (k,) their numbers.
        uv: (k, 2) their points [px].
        det: the frame's detections (``parted`` says which are a split blob's parts).
        was_crowded: the tracks linked to a crowded spot (``Detections.crowded``) in this
            camera's last frame.
        stamp_s: the frame's stamp [s].
        diameter_px: a marker's diameter in this camera [px] (0: the rule is off).
        events: the frame's events (one is added per number taken back).
    """
    parts = flagged(det, det.parted, uv)
    if diameter_px <= 0 or not parts.any() or det.parted is None:
        return markers
    siblings = det.uv[det.parted]
    last = state.last_tracks.get(camera)
    before = set() if last is None else {int(t) for t in last[1]}
    out = markers.copy()
    reach = SIBLING_DIAMETERS * diameter_px
    for k in np.flatnonzero(parts & (markers >= 0)):
        tid = int(track_ids[k])
        if tid not in before or tid not in was_crowded:
            continue
        gap = np.linalg.norm(siblings - uv[k], axis=1)
        if not ((gap > 0) & (gap < reach)).any():
            continue
        m = int(out[k])
        out[k] = UNNUMBERED
        take_back(state, camera, tid, m)
        events.append(f'{camera}: track {tid} gave back marker {m} at {stamp_s:.3f} s: its spot '
                      'parted in two and either part could be it')
    return out
