"""The two-camera tracker's checks before anything is given out: every numbered point against
the other camera's point of the same number (epipolar line, and a 3D point the marker can have
reached); a pair that fails is withheld, and the track may lose its number.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import project, triangulate_pairs
from dempath_recon.tracking.crowded_pair import blame_crowded, steady, tight_pair
from dempath_recon.tracking.link_guide import DRIFT_PX, DRIFT_WINDOW, lines_in_doubt
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.one_camera import alone
from dempath_recon.tracking.state import (
    RECENT_S,
    StereoState,
    at_stamp,
    carried_point,
    take_back,
)

LOG = logging.getLogger('dempath_recon.tracking.stereo')  # the pipeline's logger
FloatArray = NDArray[np.float64]
JUMP_SHARE = 2.0  # a running track whose link since its last passed check missed its
# prediction by more than this many doubt_link_px waits for the other camera too
MOVED_MIN = 3  # pairs that must be off at once for the view to have moved
MOVED_SHARE = 0.5  # share of the frame's checked pairs that must be off at once
JUMPED_SHARE = 1 / 3  # share of the frame's numbered tracks (and at least MOVED_MIN) whose
# links missed their predictions by more than doubt_link_px at once for the view to have jumped
DRIFT_MIN_PAIRS = 3  # pairs a frame needs for its median to count
# The calibration watch counts only pairs whose partner point is of this frame's instant: seen
# within this share of a frame period (the few ms two unsynchronised cameras expose apart) or
# moved to it along its running track. A partner kept where it was seen up to a frame earlier
# (its track has moved on since, as between live detectors) carries the marker's motion over
# that time: live at 50 FPS such pairs lay about 1.5 px off the lines with the cameras fixed,
# and the detectors warned that the cameras had moved.
SAME_INSTANT_SHARE = 0.25


def verify(state: StereoState, camera: str, track_ids: NDArray[np.int64],
           markers: NDArray[np.int32], uv: FloatArray, stamp_s: float, events: list[str],
           ) -> NDArray[np.int32]:
    """Check every numbered point against the other camera's point of the same number.

    A pair farther than ``3 * epipolar_px`` from the epipolar line (``epipolar_px`` when the
    other camera's point is of this very instant, :mod:`~dempath_recon.tracking.crowded_pair`),
    or whose 3D point the marker cannot have reached since its last accepted position, is
    withheld (-1) in this frame. The track loses that number for good if it was numbered
    after the start (epipolar line, late grid), if one of its links since its last passed
    check landed more than ``doubt_link_px`` from the prediction (the 2D linker likely took a
    neighbour for the covered marker), or if the pair is of one instant, off its line, and
    the track's spot is crowded (the other camera's track of the number loses it too when
    its spot is); otherwise the other camera is the likelier culprit and the point is only
    withheld. Pairs that pass update the marker's 3D position. (Undoing just
    the bad link instead, the track lost again with its number, was tried: on the bundled
    render it let that number re-attach to a neighbour later, 6 switches.)

    A track re-attached since its last passed check more than ``doubt_link_px`` from where
    it was expected, or linked in this frame to a faint spot (below the detector's
    threshold: ``Detections.faint``), is not given out with its number until the other
    camera confirms it (withheld, counted as ``unconfirmed``): a marker that reappears some
    way off may be a neighbour, and a wrong number is worse than none, unless no other
    marker this camera does not see now could be there at a plausible speed
    (:func:`~dempath_recon.tracking.one_camera.alone`, counted as ``confirmed_alone``).
    (Withholding it only when another marker was last seen near the spot, at any time, was
    tried: on the bundled render the switch it should stop, a side-camera re-attachment 25 px
    off after 0.2 s, stayed.)
    """
    other, markers = state.other(camera), markers.copy()
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    # a running track that jumped waits for the other camera, unless the view shakes
    jump_px = np.inf if lines_in_doubt(state) else JUMP_SHARE * state.config.doubt_link_px
    unsure = {k for k in np.flatnonzero(markers >= 0).tolist()
              if int(track_ids[k]) in tracks
              and (tracks[int(track_ids[k])].reattach_px > state.config.doubt_link_px
                   or tracks[int(track_ids[k])].link_px > jump_px
                   or tracks[int(track_ids[k])].faint_stamp == stamp_s
                   or (tracks[int(track_ids[k])].back_unchecked
                       and likelier_in_view(state, camera, int(markers[k]), uv[k], markers,
                                            stamp_s) is not None))}
    partner, gap_s = partners(state, other, markers, unsure, stamp_s)
    idx = sorted(partner)
    for k in sorted(unsure - set(idx)):
        tid = int(track_ids[k])
        if alone(state, camera, tid, int(markers[k]), uv[k], markers, stamp_s):
            tracks[tid].reattach_px = 0.0
            tracks[tid].link_px = 0.0
            state.counts[camera].confirmed_alone += 1
            events.append(f'{camera}: marker {markers[k]} re-attached off its prediction '
                          f'kept at {stamp_s:.3f} s: no other marker can be that near')
            continue
        state.counts[camera].unconfirmed += 1
        state.pending[camera][int(markers[k])] = (stamp_s, uv[k])
        off = max(tracks[tid].reattach_px, tracks[tid].link_px)
        events.append(f'{camera}: marker {markers[k]} withheld at {stamp_s:.3f} s: '
                      f'linked {off:.1f} px from its prediction (a jump, a re-attachment '
                      'or a faint spot), not yet confirmed by the other camera')
        markers[k] = UNNUMBERED
    xyz, epi = triangulate_pairs(state.cameras[camera], state.cameras[other],
                                 uv[idx], np.array([partner[k] for k in idx]))
    same_instant = np.array([gap_s[k] <= SAME_INSTANT_SHARE / state.config.fps for k in idx],
                            bool)
    note_residuals(state, camera, epi[same_instant], stamp_s, events)
    moved = frame_moved(state, markers, idx, xyz, stamp_s)
    view_jumped = jumped_together(state, camera, track_ids, markers)
    steady_view = state.config.crowded_pairs and steady(state)
    for k, x, d in zip(idx, xyz, epi, strict=True):
        m = int(markers[k])
        dist, allowed = state.positions.distance(m, stamp_s, x)
        # a doubtful re-attachment is confirmed only by the test that numbers a new track, and
        # so is a pair seen at one instant (no motion along a track between its two points)
        tight = k in unsure or (steady_view and tight_pair(state, other, m, stamp_s))
        epi_ok = state.config.epipolar_px if tight else 3 * state.config.epipolar_px
        track = tracks.get(int(track_ids[k]))
        back = track is not None and track.back_unchecked
        rival = likelier_marker(state, other, m, x, markers, stamp_s) if back else None
        if d <= epi_ok and dist <= allowed and rival is None:
            state.positions.accept(m, stamp_s, x)
            state.pending[camera].pop(m, None)
            state.confirmed[camera][int(track_ids[k])] = stamp_s
            if track is not None:
                track.link_px = 0.0
                track.reattach_px = 0.0
                track.back_unchecked = False
            continue
        counts = state.counts[camera]
        counts.withheld += 1
        if d > epi_ok:
            counts.epipolar_conflicts += 1
            why = f'{d:.1f} px off the epipolar line'
        elif rival is not None:
            counts.motion_conflicts += 1
            why = f'its 3D point is nearer where the bed carried marker {rival}'
        else:
            counts.position_conflicts += 1
            why = f'3D point {1e3 * dist:.0f} mm from its last position (at most ' \
                  f'{1e3 * allowed:.0f} mm)'
        markers[k] = UNNUMBERED
        tid = int(track_ids[k])
        jump = tracks[tid].link_px if tid in tracks else 0.0
        blamed = (False, False)  # a same-instant pair off its line: the crowded track's fault
        if k not in unsure and tight and d <= 3 * state.config.epipolar_px and dist <= allowed:
            blamed = blame_crowded(state, camera, tid, m, stamp_s)
        if moved and d <= epi_ok and rival is None:
            why += ("; most of the frame's pairs moved together (the cameras moved, not "
                    'the markers): numbers kept')
        elif tid in state.late_numbered[camera] or rival is not None \
                or (jump > state.config.doubt_link_px and not view_jumped) or blamed[0]:
            state.late_numbered[camera].discard(tid)
            take_back(state, camera, tid, m)
            why += '; its number taken back'
        if blamed[1]:
            why += f' (and in {other}: its spot is crowded)'
        if rival is not None:  # the other camera's unchecked re-attachment is the same spot
            for t in state.trackers[other].tracks:
                if t.marker == m and t.back_unchecked:
                    take_back(state, other, t.track_id, m)
                    state.pending[other].pop(m, None)
                    why += f' (and in {other})'
        msg = f'{camera}: marker {m} withheld at {stamp_s:.3f} s: {why}'
        events.append(msg)
        LOG.warning(msg)
    return markers


def jumped_together(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                    markers: NDArray[np.int32]) -> bool:
    """Whether at least ``JUMPED_SHARE`` of the frame's numbered tracks (and ``MOVED_MIN`` of
    them) linked more than ``doubt_link_px`` off their predictions at once: the view jumped
    (shake, a knock), so such a miss says nothing about a track taking a neighbour, and a
    failed pair check withholds the point without taking its number back. (On the variation
    shaken by 3 px, four of the front's ten tracks missed by 6.7-7.8 px in one frame, failed
    the 3D check by 0-2 mm, lost their numbers for good and were never numbered again.)"""
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    links = [tracks[int(t)].link_px for t, m in zip(track_ids, markers, strict=True)
             if m >= 0 and int(t) in tracks]
    off = sum(px > state.config.doubt_link_px for px in links)
    return off >= max(MOVED_MIN, JUMPED_SHARE * len(links))


def frame_moved(state: StereoState, markers: NDArray[np.int32], idx: list[int],
                xyz: FloatArray, stamp_s: float) -> bool:
    """Whether at least ``MOVED_SHARE`` of the frame's pairs (and ``MOVED_MIN`` of them) lie
    farther from their markers' last positions than the markers can have gone: the whole
    view moved at once (camera shake, a knock), which says nothing about identities. Such
    pairs are withheld but keep their numbers (on a variation shaken by 3 px, one frame put
    all ten of the front camera's pairs 20-26 mm off and took every number back: the front
    numbered nothing for the rest of the pass)."""
    if len(idx) < MOVED_MIN:
        return False
    off = 0
    for k, x in zip(idx, xyz, strict=True):
        dist, allowed = state.positions.distance(int(markers[k]), stamp_s, x)
        off += int(dist > allowed)
    return off >= max(MOVED_MIN, MOVED_SHARE * len(idx))


def note_residuals(state: StereoState, camera: str, epi: FloatArray, stamp_s: float,
                   events: list[str]) -> None:
    """Watch the calibration: the median distance of a frame's numbered pairs from their
    epipolar lines, over the last ``DRIFT_WINDOW`` frames with at least ``DRIFT_MIN_PAIRS``
    pairs, above ``DRIFT_PX`` means the cameras no longer sit where the calibration put them
    (shake, a knock on the rig). Such frames are counted (``drift_frames``), the median so
    far is ``pair_residual_px``, and the first frame of each such stretch says so in its
    events. On the bundled render the frames' medians are 0.76 px (0.93 with noise and JPEG
    60) and 2.5 px with the image shaken by up to 3 px a frame."""
    if len(epi) < DRIFT_MIN_PAIRS:
        return
    seen = state.residuals[camera]
    seen.append(float(np.median(epi)))
    counts = state.counts[camera]
    counts.pair_residual_px = float(np.median(seen))
    recent = float(np.median(seen[-DRIFT_WINDOW:]))
    if len(seen) < DRIFT_WINDOW or recent <= DRIFT_PX:
        return
    counts.drift_frames += 1
    if len(seen) == DRIFT_WINDOW or float(np.median(seen[-DRIFT_WINDOW - 1:-1])) <= DRIFT_PX:
        msg = (f'{camera}: the pairs lie {recent:.1f} px (median of the last {DRIFT_WINDOW} '
               f'frames) from their epipolar lines at {stamp_s:.3f} s, more than {DRIFT_PX} px: '
               'the cameras may have moved since the calibration (shake, a knock); '
               'recalibrate, or expect 3D errors of a few mm')
        events.append(msg)
        LOG.warning(msg)


def partners(state: StereoState, other: str, markers: NDArray[np.int32], unsure: set[int],
             stamp_s: float) -> tuple[dict[int, FloatArray], dict[int, float]]:
    """The other camera's point (2,) px of each numbered detection's marker, seen within a
    frame period: its given-out point, or for an unsure re-attachment (index in ``unsure``)
    also its withheld, unconfirmed one (two cameras that both lost a marker re-attach it
    with no given-out point to check against; the pair can confirm both); and how far in time
    each partner's point is from ``stamp_s`` [s] (0 when moved to it along its track)."""
    out: dict[int, FloatArray] = {}
    gap: dict[int, float] = {}
    for k in np.flatnonzero(markers >= 0).tolist():
        m = int(markers[k])
        sources = (state.latest[other], state.pending[other]) if k in unsure \
            else (state.latest[other],)
        for source in sources:
            hit = source.get(m)
            if hit is not None and abs(hit[0] - stamp_s) <= 1.0 / state.config.fps:
                out[k] = at_stamp(state, other, m, hit, stamp_s)
                # moved along its running track to this instant, or seen at it: no gap left
                moved = not np.array_equal(out[k], hit[1])
                gap[k] = 0.0 if moved else abs(hit[0] - stamp_s)
                break
    return out, gap


def likelier_marker(state: StereoState, other: str, marker: int, xyz: FloatArray,
                    markers: NDArray[np.int32], stamp_s: float) -> int | None:
    """A marker the bed's motion places nearer a doubtful pair's 3D point than ``marker``.

    Two cameras that both lost a marker can both re-attach its track onto a neighbour that
    reappears nearby: the pair is then consistent (one marker seen twice) but it is the
    neighbour. Each marker not given out in this frame nor by the other camera within
    ``RECENT_S`` (a rival), and ``marker`` itself, is placed where the bed has carried it
    (:func:`~dempath_recon.tracking.state.carried_point`); the rival nearest the point is
    returned when it is nearer than ``marker`` and within what it can have reached. None when
    ``marker`` cannot be placed or no rival is nearer (a rival that cannot be placed is not
    counted: it would withhold every re-attachment while one marker stays covered).
    """
    taken = {int(m) for m in markers if m >= 0} | {
        m for m, (t, _) in state.latest[other].items() if abs(t - stamp_s) <= RECENT_S}
    return _nearer_rival(state, marker, taken, stamp_s,
                         lambda at: float(np.linalg.norm(xyz - at)), 'm')


def likelier_in_view(state: StereoState, camera: str, marker: int, uv: FloatArray,
                     markers: NDArray[np.int32], stamp_s: float) -> int | None:
    """The same test on one camera's evidence: a marker whose carried place, seen in
    ``camera``, is nearer a re-attached spot ``uv`` (2,) px than ``marker``'s. Such a spot
    waits for the other camera (as a re-attachment far off its prediction does)."""
    cam = state.cameras[camera]
    taken = {int(m) for m in markers if m >= 0}
    return _nearer_rival(state, marker, taken, stamp_s,
                         lambda at: float(np.linalg.norm(project(cam, at[None])[0] - uv)),
                         'px')


def _nearer_rival(state: StereoState, marker: int, taken: set[int], stamp_s: float,
                  distance: Callable[[FloatArray], float], unit: str) -> int | None:
    """The marker not in ``taken`` whose carried place is nearest (``distance``), when it is
    nearer than ``marker``'s (and, in 3D, within its reach); None otherwise."""
    own = carried_point(state, marker, stamp_s)
    if own is None:
        return None
    own_dist = distance(own[0])
    best: tuple[float, int] | None = None
    for m in state.config.grid.points()[0].tolist():
        if m == marker or m in taken:
            continue
        placed = carried_point(state, m, stamp_s)
        if placed is None:
            continue
        dist = distance(placed[0])
        reach = state.config.position_gate_m + state.config.max_speed_m_s * (
            stamp_s - placed[1])
        if dist < own_dist and (unit == 'px' or dist <= reach) \
                and (best is None or dist < best[0]):
            best = (dist, m)
    return None if best is None else best[1]
