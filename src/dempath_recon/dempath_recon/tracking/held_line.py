"""Whether a track of one camera and a track of the other held on each other's epipolar line
over their common frames, not only in one frame.

On an oblique view the lines of several markers pass within the numbering's ``epipolar_px``
(4 px) of one spot: on a tuning render a side spot lay 2-4 px from the lines of five front
spots, frame after frame, while its right partner stayed at 0.2-0.7 px. A pair is therefore
judged by its distances over the frames both tracks were linked in (each point of the other
camera moved to this camera's stamp along its track: the cameras are not synchronised), every
one within ``epipolar_px`` and their mean within a few times the distance of the pairs already
numbered now (``pair_checks.note_residuals``), which follows the look's noise, blur and
calibration.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import epipolar_distance
from dempath_recon.tracking.linker import Track
from dempath_recon.tracking.state import StereoState

FloatArray = NDArray[np.float64]
LINE_FACTOR = 2.0  # a pair's mean distance from the epipolar line over its common frames is at
# most this many times the frames' median of numbered pairs (``pair_checks.note_residuals``):
# on a tuning render right pairs held at 0.2-0.7 px, wrong ones on a crowded line at 1.5-4 px
LINE_FLOOR_PX = 1.0  # ... but never below this [px]
RESIDUAL_FRAMES = 25  # the median of numbered pairs is taken over this many last frames


def held_together(state: StereoState, camera: str, track: Track, partner: Track,
                  frames: int) -> bool:
    """Whether ``track`` (of ``camera``) and ``partner`` (of the other camera) held on each
    other's epipolar line (:func:`held_on_line`) over ``track``'s last ``frames`` frames, or
    as many as both were linked in (at least one)."""
    recent = track.history[-frames:]
    at = None
    while recent and at is None:
        at = track_at(partner, [s for s, _, _ in recent], state.config.fps)
        if at is None:
            recent = recent[1:]
    if at is None:
        return False
    mine = np.array([(u, v) for _, u, v in recent])
    d = epipolar_distance(state.cameras[camera], state.cameras[state.other(camera)], mine, at)
    return held_on_line(state, np.diagonal(d))


def held_on_line(state: StereoState, dist: FloatArray) -> bool:
    """Whether a pair's distances from the epipolar line over its common frames (n,) px say it
    held on the line: every one within ``epipolar_px``, their mean within ``LINE_FACTOR``
    times the recent median of the numbered pairs (``LINE_FLOOR_PX`` at least; half of
    ``epipolar_px`` before any pair was checked)."""
    seen = [r for c in state.cameras for r in state.residuals[c][-RESIDUAL_FRAMES:]]
    tol = min(max(LINE_FACTOR * float(np.median(seen)), LINE_FLOOR_PX), state.config.epipolar_px) \
        if seen else 0.5 * state.config.epipolar_px
    return float(dist.max()) <= state.config.epipolar_px and float(dist.mean()) <= tol


def track_at(track: Track, stamps: list[float], fps: float) -> FloatArray | None:
    """(n, 2) px: ``track`` at each of ``stamps`` (the other camera's, ascending): between two
    frames it was linked in, on the straight link between them; after its last, moved on
    along its velocity for at most a frame period (the other camera's newest frame is often
    the later one); None when any stamp falls outside its frames or in a gap of its links."""
    times = np.array([h[0] for h in track.history])
    points = np.array([(h[1], h[2]) for h in track.history])
    period = 1.0 / fps
    out = []
    for s in stamps:
        if s > times[-1]:
            if s - times[-1] > period:
                return None
            out.append(points[-1] + track.velocity * (s - times[-1]))
            continue
        i = int(np.searchsorted(times, s))
        if times[i] == s or (i == 0 and times[0] - s <= 0.5 * period):
            out.append(points[i])
        elif i == 0 or times[i] - times[i - 1] > 1.5 * period:
            return None
        else:
            w = (s - times[i - 1]) / (times[i] - times[i - 1])
            out.append((1 - w) * points[i - 1] + w * points[i])
    return np.array(out, np.float64)
