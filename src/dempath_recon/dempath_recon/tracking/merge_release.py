"""One camera's own evidence that two markers merged into one spot: the number is released.

A marker passing over another in one camera's view (a crossing the other camera, 72 degrees
away, never sees at the same instant) shows there as two blobs running into one. The linker
gives that one spot to one of the two tracks and leaves the other lost; when one of the two
markers then sinks or stays hidden, the surviving blob is followed by whichever track took it,
with links a pixel or two long that no link test can doubt, and no pair check reaches a marker
only this camera sees. On the ten long-pass tuning looks most identity switches left began this
way (``t105_coh``: the front's track of marker 14, standing still, took the blob marker 9 made
running into it, 14 sank and the track followed 9 for the rest of the pass; ``t113_asis``,
``t107_fast``, ``l93_long`` alike).

Two signs of one camera say "merged" together (:func:`merged_spots`):

- a track running in the camera's last frame is left without a spot in this one while its
  prediction lies within ``MERGE_DIAMETERS`` marker image diameters of the spot another running
  track took (two predictions fall in one spot, one of them goes unlinked), and
- that spot grew: its radius of gyration (``Detections.size_px``) is at least ``GROWTH`` times
  the median of the taking track's last ``SIZE_FRAMES`` spots (two blobs running into one
  widen it; a marker only passing near a lost neighbour does not).

On the merge events of the ten long-pass tuning looks (a running track left unlinked within
8 px of another running track's spot: 30 events) the taking track went on with the other
marker (in the truth, within six frames) after 11 of the 14 whose spot grew by 1.15 or more,
and after 5 of the 16 below.

The taking track's number is then taken back (:func:`~dempath_recon.tracking.state.take_back`:
refused by that track; a re-attachment that jumps forgets it): the spot may be either marker,
and which one survives the merge nothing in this camera can say. The numbering rules may name
the track again from other evidence (the other camera's pair on its epipolar line); unnumbered
is better than wrong. Its points held for the publication delay stay unnumbered whatever
number it takes later (:func:`keep_released_free`): the number that names it again is evidence
of the frame it was given in, not of the frames since the merge (given back into them, it named
the blob's other marker: ``t113_carriage``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.detect import own_detections
from dempath_recon.tracking.state import StereoState, take_back

FloatArray = NDArray[np.float64]

MERGE_DIAMETERS = 1.0  # a track left unlinked whose prediction lies within this many marker
# image diameters of another track's spot may have merged into it
GROWTH = 1.15  # ... if that spot's radius of gyration grew to this share of the taking track's
# recent median (1.15 and 1.2 gave the same numbered right on 39 tuning looks, 1.15 fewer switches
# and wrong pairs; 1.1 and 1.05 cost 1-4 points on three looks for one switch less)
SIZE_FRAMES = 5  # the taking track's last spots the median is taken over


def spot_sizes(uv: FloatArray, det_uv: FloatArray, det_size: FloatArray) -> FloatArray:
    """(k,) the radius of gyration [px] of the detection each linked point ``uv`` (k, 2) px
    took (the linker gives out the detection's own centre); NaN for a point on no detection
    (a faint spot)."""
    own = own_detections(det_uv, uv)
    return np.where(own >= 0, np.asarray(det_size, np.float64)[np.maximum(own, 0)], np.nan) \
        if len(det_uv) else np.full(len(uv), np.nan)


def merged_spots(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                 uv: FloatArray, sizes: FloatArray, stamp_s: float, diameter_px: float,
                 ) -> NDArray[np.bool_]:
    """(k,) whether each point of this frame is a spot a neighbour's blob merged into (the
    module docstring's two signs); notes every spot's size for the next frames."""
    history = state.spot_sizes[camera]
    out = np.zeros(len(track_ids), bool)
    last = state.last_tracks[camera]
    if last is not None and diameter_px > 0 and len(track_ids):
        before = {int(t) for t in last[1]}
        tracks = {t.track_id: t for t in state.trackers[camera].tracks}
        gone = [t for t in tracks.values()
                if t.lost and t.track_id in before and t.last_stamp_s == last[0]]
        if gone:
            pred = np.array([t.uv + t.velocity * (stamp_s - t.last_stamp_s) for t in gone])
            near = np.linalg.norm(uv[:, None] - pred[None], axis=2).min(axis=1)
            for k, tid in enumerate(track_ids.tolist()):
                seen = history.get(tid, [])
                if tid not in before or near[k] > MERGE_DIAMETERS * diameter_px or not seen:
                    continue
                out[k] = bool(sizes[k] >= GROWTH * float(np.median(seen)))
    state.spot_sizes[camera] = {
        tid: ([*history.get(tid, []), float(s)] if np.isfinite(s) else history.get(tid, []))
        [-SIZE_FRAMES:] for tid, s in zip(track_ids.tolist(), sizes.tolist(), strict=True)}
    return out


def keep_released_free(state: StereoState, camera: str, stamp_s: float) -> None:
    """Before this frame's numbering: keep the points of ``camera``'s released tracks (still
    unnumbered) in the frames held from before ``stamp_s`` [s] unnumbered
    (:meth:`~dempath_recon.tracking.release.ReleaseQueue.keep_free`); forget the tracks
    numbered again or dropped."""
    freed = state.merge_freed[camera]
    if not freed:
        return
    unnumbered = {t.track_id for t in state.trackers[camera].tracks if t.marker < 0}
    for tid in sorted(freed):
        if tid in unnumbered:
            state.queue.keep_free(camera, tid, stamp_s)
        else:
            freed.discard(tid)


def release_merged(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                   markers: NDArray[np.int32], merged: NDArray[np.bool_], stamp_s: float,
                   events: list[str]) -> NDArray[np.int32]:
    """``markers`` (k,) with the numbers of the ``merged`` spots' tracks taken back (refused
    by those tracks, watched by :func:`keep_released_free`) and the frame's events noting
    each."""
    out = markers.copy()
    for k in np.flatnonzero(merged & (markers >= 0)).tolist():
        tid, number = int(track_ids[k]), int(markers[k])
        take_back(state, camera, tid, number)
        state.merge_freed[camera].add(tid)
        out[k] = -1
        events.append(f'{camera}: track {tid} gave back marker {number} at {stamp_s:.3f} s: '
                      "a neighbour's blob merged into its spot")
    return out
