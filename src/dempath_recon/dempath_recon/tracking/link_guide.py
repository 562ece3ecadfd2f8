"""The other camera inside the frame-to-frame link: which detections a numbered track may not
take, and which linked spots may hold two markers.

Linking one camera's detections by image motion alone let a track whose marker was covered
jump onto a neighbour that reappeared beside it (on a tuning render the side camera's track of
marker 3 took marker 2's spot 17 px off its prediction, inside the 25 px gate); the pair check
found the pair off its epipolar line only afterwards, once the wrong number had gone out.
Here the constraint enters the assignment itself: a numbered track whose marker the other
camera saw within a frame period (its sighting moved to this frame's stamp along its track,
:func:`~dempath_recon.tracking.state.at_stamp`) may not be linked to a detection farther
than the pair check's own tolerance (``3 * epipolar_px``) from that sighting's epipolar line,
nor, by a jump of more than ``doubt_link_px`` off its prediction, to one farther than
``epipolar_px`` (the tolerance that numbers a new track, and confirms a doubtful
re-attachment): such a link would be withheld by the pair check
(:func:`~dempath_recon.tracking.pair_checks.verify`) anyway, and made, it moves the track onto
another marker. (Not while the pairs lie off their lines: shake, :func:`lines_in_doubt`.)
Barred, the track stays lost with its number, and the detection can re-attach the track of the
marker it is, or start a new one.

A spot linked to one track while another track, lost within ``MERGE_S``, was last seen
within a marker's diameter of it may be both markers merged into one blob (two markers
aligned along this camera's line of sight: one camera sees one spot, the other two): its
number is withheld for that frame (:func:`ambiguous_spots`); the track keeps it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import epipolar_distance
from dempath_recon.tracking.linker import MarkerTracker, TrackFrame
from dempath_recon.tracking.state import StereoState, at_stamp

DRIFT_PX = 1.5  # median epipolar distance of checked pairs above which the calibration is
# suspect [px] (the bundled render's frames: 0.76 px, at most 0.93 with noise; shaken 3 px: 2.5)
DRIFT_WINDOW = 10  # checked frames of a camera the median is taken over

FloatArray = NDArray[np.float64]
EPIPOLAR_SHARE = 3.0  # a link is barred beyond this many ``epipolar_px`` from the line (the
# tolerance the pair check gives a numbered track's pair)
DOUBT_FRAMES = 3  # checked frames needed before the lines are doubted
MERGE_S = 0.1  # a track lost this long ago [s] (five frames at 50 FPS) can still be merged
# into a neighbour's spot; after that its marker is taken to be covered, not merged
MERGE_DIAMETERS = 1.0  # a lost track last seen within this many marker diameters of a spot


def barred_links(state: StereoState, camera: str, uv: FloatArray, stamp_s: float,
                 ) -> dict[int, NDArray[np.bool_]]:
    """Track id -> (n,) the detections ``uv`` (n, 2) px that track may not be linked to:
    those off the epipolar line of the other camera's recent sighting of its marker (beyond
    ``3 * epipolar_px``, or beyond ``epipolar_px`` for a link farther than ``doubt_link_px``
    from the track's prediction)."""
    if lines_in_doubt(state):
        return {}
    other = state.other(camera)
    seen = state.latest[other]
    period = 1.0 / state.config.fps
    tracker = state.trackers[camera]
    rows: list[tuple[int, FloatArray, FloatArray]] = []  # (track id, other's px, predicted px)
    for track in tracker.tracks:
        hit = seen.get(track.marker) if track.marker >= 0 else None
        if hit is not None and abs(hit[0] - stamp_s) <= period:
            rows.append((track.track_id, at_stamp(state, other, track.marker, hit, stamp_s),
                         track.predict(stamp_s, tracker.config.velocity_decay)))
    if not rows or not len(uv):
        return {}
    epi = epipolar_distance(state.cameras[other], state.cameras[camera],
                            np.array([r[1] for r in rows]), uv)  # (tracks, n) px
    jump = np.linalg.norm(np.array([r[2] for r in rows])[:, None] - uv[None], axis=2)
    tight = state.config.epipolar_px
    bar = (epi > EPIPOLAR_SHARE * tight) | ((epi > tight) & (jump > state.config.doubt_link_px))
    return {tid: bar[i] for i, (tid, _, _) in enumerate(rows)}


def lines_in_doubt(state: StereoState) -> bool:
    """Whether the numbered pairs of either camera lie farther from their epipolar lines than
    the calibration allows (median of the last ``DRIFT_WINDOW`` checked frames, at least
    ``DOUBT_FRAMES`` of them, above ``DRIFT_PX``: shake, a knock): then the lines cannot
    decide links (with 3 px shake, barring cost 7 % of the numbers on a tuning variation)."""
    for seen in state.residuals.values():
        recent = seen[-DRIFT_WINDOW:]
        if len(recent) >= DOUBT_FRAMES and float(np.median(recent)) > DRIFT_PX:
            return True
    return False


def ambiguous_spots(tracker: MarkerTracker, frame: TrackFrame, diameter_px: float,
                    ) -> NDArray[np.bool_]:
    """(k,) whether each of the frame's numbered points may hold two markers: another track,
    lost at most ``MERGE_S`` ago, was last seen within ``MERGE_DIAMETERS`` marker diameters
    (``diameter_px``, 0: never) of it."""
    out = np.zeros(len(frame.uv), bool)
    if diameter_px <= 0 or not len(frame.uv):
        return out
    near = [t.uv for t in tracker.tracks
            if t.lost and frame.stamp_s - t.last_stamp_s <= MERGE_S + 1e-9]
    if not near:
        return out
    d = np.linalg.norm(frame.uv[:, None] - np.array(near)[None], axis=2).min(axis=1)
    return np.asarray((frame.markers >= 0) & (d <= MERGE_DIAMETERS * diameter_px), bool)
