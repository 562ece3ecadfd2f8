"""Which track loses its number when a pair seen at one instant lies off its epipolar line: the
one on a crowded spot.

After the tool passes, markers slide over each other, sink and come back. A track numbered
right at the grid fit then follows its marker onto a spot a neighbour shares (the two images
merge into one blob), and when its own marker sinks the blob is the neighbour's: the track's
next links are a pixel or two long and no link test sees the take-over (tuning look
``t113_asis``: the front's track of marker 4 ended on marker 3, 12 mm away, nearly along the
epipolar direction). Its pair with the other camera's right track of the number then lies a
few pixels off the epipolar line, well inside the three ``epipolar_px`` a numbered pair is
allowed (that allowance covers a partner moved to this instant along its track; partners seen
within a few ms lie within 3.3 px of their lines, 99.9 % of 2,836 right pairs of the ten
long-pass tuning looks), so the pair passed, and once the other camera lost its marker the
wrong number went out unchecked.

So a pair whose partner was seen at this very instant (within ``SAME_INSTANT_SHARE`` of a
frame period, not moved along its track) in a steady view (:func:`steady`) is held to
``epipolar_px``, the tolerance that numbers a new track (:func:`tight_pair`), and when it
fails there (but passes the looser test) the number is taken back from whichever of the two
tracks is crowded: another track of its camera, seen within ``CROWD_S``, lies within
``CROWD_DIAMETERS`` marker image diameters of it (:func:`crowded`, :func:`blame_crowded`).
Both crowded: both lose it. Neither: the point is only withheld, as before (nothing says
which camera is wrong). A number taken back is refused by that track
(:func:`~dempath_recon.tracking.state.take_back`); the numbering rules
can number its marker again by other evidence: unnumbered is better than wrong. A track blamed
while it was on the neighbour often comes back to its own marker: :func:`give_back` returns
the number once its same-instant pairs with the other camera's track of it pass the strict
test over ``GIVE_BACK_FRAMES`` frames in a row (``tune6_default``, ``r121_fast``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import triangulate_pairs
from dempath_recon.tracking.link_guide import DOUBT_FRAMES, DRIFT_WINDOW
from dempath_recon.tracking.state import StereoState, give_late, take_back

FloatArray = NDArray[np.float64]

SAME_INSTANT_SHARE = 0.25  # a partner seen within this share of a frame period is of this
# instant (the few ms two unsynchronised cameras expose apart: 3 ms in the twin's renders)
STEADY_PX = 1.25  # the view is steady while its pairs' recent median distance from their lines
# is within this [px] (right pairs of the long-pass tuning looks: median 0.49 px)
CROWD_DIAMETERS = 1.5  # another track this many marker image diameters away crowds a track
# (two markers whose blobs touch or merge; 1.25-1.75 gave the same on the tuning looks)
GIVE_BACK_FRAMES = 3  # clear frames in a row that give a taken-back number back (see give_back)
CROWDED_SHARE = 0.5  # ... where a crowded spot's pair must lie within this share of epipolar_px
CROWD_S = 0.5  # ... if seen within this long [s] (a neighbour lost into the blob; 0.1-1 s
# gave the same on the tuning looks)


def tight_pair(state: StereoState, other: str, marker: int, stamp_s: float) -> bool:
    """Whether the other camera saw ``marker`` within ``SAME_INSTANT_SHARE`` of a frame
    period of ``stamp_s`` [s], so the pair is held to ``epipolar_px`` rather than three
    times it (no motion along a track stands between the two points). The caller also asks
    that the view be steady (:func:`steady`, once a frame)."""
    hit = state.latest[other].get(marker)
    return hit is not None and abs(hit[0] - stamp_s) <= SAME_INSTANT_SHARE / state.config.fps


def steady(state: StereoState) -> bool:
    """Whether both cameras' checked pairs lie close to their lines: the median of each
    camera's last ``DRIFT_WINDOW`` frame medians (at least ``DOUBT_FRAMES`` of them) within
    ``STEADY_PX``. A shaken view puts right pairs several pixels off their lines (on the
    bench's variation shaken by 3 px the tight test took 4 right marker-frames, 3 of them
    still with only :func:`~dempath_recon.tracking.link_guide.lines_in_doubt`, whose 1.5 px
    a 3 px shake does not always pass)."""
    for seen in state.residuals.values():
        recent = seen[-DRIFT_WINDOW:]
        if len(recent) < DOUBT_FRAMES or float(np.median(recent)) > STEADY_PX:
            return False
    return True


def crowded(state: StereoState, camera: str, track_id: int, stamp_s: float) -> bool:
    """Whether another track of ``camera``, seen within ``CROWD_S`` of ``stamp_s`` [s], was
    last seen within ``CROWD_DIAMETERS`` marker image diameters of the track's position
    (the diameter is the tracker's ``hold_rival_px``, set per camera from the calibration;
    unset or 0: never crowded)."""
    tracker = state.trackers[camera]
    diameter = tracker.config.hold_rival_px or 0.0
    own = next((t for t in tracker.tracks if t.track_id == track_id), None)
    if own is None or diameter <= 0:
        return False
    for track in tracker.tracks:
        if track.track_id != track_id and stamp_s - track.last_stamp_s <= CROWD_S \
                and float(np.linalg.norm(track.uv - own.uv)) <= CROWD_DIAMETERS * diameter:
            return True
    return False


def blame_crowded(state: StereoState, camera: str, track_id: int, marker: int,
                  stamp_s: float) -> tuple[bool, bool]:
    """Take ``marker`` back from the crowded tracks of a same-instant pair that lies off its
    epipolar line: ``camera``'s ``track_id`` and the other camera's track of the number.

    Returns:
        ``(this, other)``: whether ``camera``'s track is to lose the number (the caller takes
        it back, with its own bookkeeping) and whether the other camera's track lost it here.
    """
    other = state.other(camera)
    partner = next((t.track_id for t in state.trackers[other].tracks if t.marker == marker),
                   None)
    other_crowded = partner is not None and crowded(state, other, partner, stamp_s)
    if other_crowded and partner is not None:
        take_back(state, other, partner, marker)
        state.pending[other].pop(marker, None)
        state.crowd_taken[other][partner] = (marker, 0, stamp_s)
    this = crowded(state, camera, track_id, stamp_s)
    if this:
        state.crowd_taken[camera][track_id] = (marker, 0, stamp_s)
    return this, other_crowded


def give_back(state: StereoState, camera: str, track_ids: NDArray[np.int64],
              markers: NDArray[np.int32], uv: FloatArray, stamp_s: float, events: list[str],
              ) -> NDArray[np.int32]:
    """``markers`` (k,) of this frame's tracks ``track_ids`` (k,) at ``uv`` (k, 2) px, with
    a number :func:`blame_crowded` took back given back to its track once the track is on its
    own marker again: over ``GIVE_BACK_FRAMES`` of the camera's frames in a row, the view
    steady, the track running, no other track of either camera's frame holding the number
    but the other camera's track of it, seen at this very instant, whose pair with the track
    lies within ``epipolar_px`` of its line (the test that numbers a new track; within
    ``CROWDED_SHARE`` of it while the track's spot is still crowded) and at a 3D point the
    marker can have reached. Any frame that fails starts the
    count again. The number goes back as a late number (a contradicting pair check takes it
    back again), and the track's points held for the publication delay from before the
    first clear frame stay unnumbered (on tuning look ``tune6_default`` they were on a sunk
    neighbour's spot: 3 switches)."""
    taken = state.crowd_taken[camera]
    if not taken:
        return markers
    out, other = markers.copy(), state.other(camera)
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    row = {int(t): k for k, t in enumerate(track_ids.tolist())}
    view_ok = steady(state)
    for tid, (number, clear, since) in sorted(taken.items()):
        track = tracks.get(tid)
        if track is None or track.marker >= 0:
            del taken[tid]
            continue
        k = row.get(tid)
        ok = k is not None and view_ok and not track.lost and int(out[k]) < 0 \
            and number not in out.tolist() \
            and _pair_clear(state, camera, uv[k], number, stamp_s,
                            CROWDED_SHARE if crowded(state, camera, tid, stamp_s) else 1.0)
        clear, since = (clear + 1, since if clear else stamp_s) if ok else (0, stamp_s)
        if clear < GIVE_BACK_FRAMES or k is None:
            taken[tid] = (number, clear, since)
            continue
        del taken[tid]
        give_late(state, camera, track, number)
        state.queue.keep_free(camera, tid, since)
        out[k] = number
        events.append(f'{camera}: track {tid} given marker {number} back at {stamp_s:.3f} s: '
                      f'paired on its line with {other} at one instant for '
                      f'{GIVE_BACK_FRAMES} frames')
    return out


def _pair_clear(state: StereoState, camera: str, uv: FloatArray, number: int,
                stamp_s: float, share: float) -> bool:
    """Whether the other camera gave ``number`` out at this very instant, from a running
    track that holds it, and the pair with ``uv`` (2,) px lies within ``share`` times
    ``epipolar_px`` of its line at a 3D point the marker can have reached."""
    other = state.other(camera)
    holder = [t for t in state.trackers[other].tracks if t.marker == number and not t.lost]
    if len(holder) != 1 or not tight_pair(state, other, number, stamp_s):
        return False
    seen = state.latest[other][number][1]
    xyz, epi = triangulate_pairs(state.cameras[camera], state.cameras[other], uv[None],
                                 np.asarray(seen, np.float64)[None])
    dist, allowed = state.positions.distance(number, stamp_s, xyz[0])
    return float(epi[0]) <= share * state.config.epipolar_px and dist <= allowed
