"""A numbered track whose spot parts in two gives its number back.

Two touching markers can show as one spot for a while (the detector's split could not part
them, or they lay on one line of sight) and a track, numbered on that spot, follows its centre,
which lies between the two markers. When the spot parts (the markers draw apart, or the
detector's split now parts them: ``Detections.parted``), the track links to whichever part lies
nearer its prediction: which marker that is, the spot's history cannot say. On a tuning
re-render (seed 6, the front camera) the track of a spot holding markers 9 and 10, numbered 9
at the grid fit, took 10's part when the split parted them and kept 9 for three frames (a wrong
number in 2D; marker 9's part started a new track).

The rule: a numbered track that was linked last frame to a spot that was not a split's part and
is linked now to a part of a split blob with another part within ``SIBLING_DIAMETERS`` marker
diameters of it loses its number for good (refused, as a check's revocation), so the numbering
may number the parts afresh, each by its own evidence; its point is not given out with that
number.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.state import StereoState

FloatArray = NDArray[np.float64]
SIBLING_DIAMETERS = 1.5  # parts of one split blob lie closer than this many diameters


def on_parts(det: Detections, uv: FloatArray) -> NDArray[np.bool_]:
    """(k,) whether each of the frame's points ``uv`` (k, 2) [px] is a part of a split blob
    (each point is one of ``det``'s)."""
    if det.parted is None or not det.parted.any():
        return np.zeros(len(uv), np.bool_)
    parts = {tuple(p) for p in det.uv[det.parted].tolist()}
    return np.array([tuple(p) in parts for p in uv.tolist()], np.bool_)


def revoke_at_parting(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                      markers: NDArray[np.int32], uv: FloatArray, parts: NDArray[np.bool_],
                      was_on_part: set[int], stamp_s: float, diameter_px: float,
                      events: list[str]) -> NDArray[np.int32]:
    """``markers`` with the numbers of tracks whose spot just parted taken back.

    Args:
        state: the tracker's state (its linkers and refusals are updated).
        camera: this frame's camera.
        track_ids: (k,) the frame's tracks.
        markers: (k,) their numbers.
        uv: (k, 2) their points [px].
        parts: (k,) which points are parts of a split blob (``on_parts``).
        was_on_part: the tracks linked to a split's part in this camera's last frame.
        stamp_s: the frame's stamp [s].
        diameter_px: a marker's diameter in this camera [px] (0: the rule is off).
        events: the frame's events (one is added per number taken back).
    """
    if diameter_px <= 0 or not parts.any():
        return markers
    last = state.last_tracks.get(camera)
    before = set() if last is None else {int(t) for t in last[1]}
    out = markers.copy()
    reach = SIBLING_DIAMETERS * diameter_px
    for k in np.flatnonzero(parts & (markers >= 0)):
        tid = int(track_ids[k])
        if tid not in before or tid in was_on_part:
            continue
        gap = np.linalg.norm(uv[parts] - uv[k], axis=1)
        if not ((gap > 0) & (gap < reach)).any():
            continue
        m = int(out[k])
        out[k] = UNNUMBERED
        state.refused[camera].add((tid, m))
        state.trackers[camera].number(tid, UNNUMBERED)
        state.counts[camera].revoked += 1
        events.append(f'{camera}: track {tid} gave back marker {m} at {stamp_s:.3f} s: its spot '
                      'parted in two and either part could be it')
    return out
