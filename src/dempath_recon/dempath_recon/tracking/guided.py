"""Guided recovery: a faint spot looked for only where a known marker must be, kept only when
both cameras agree.

At dusk (light x0.3, 12 ms shutter) whole markers read 0.11-0.15 chroma, smeared ones about
0.06 and half-buried ones 0.03, under the detector's fixed bar (0.15) though clear of the sand
(at most -0.07). Every frame-wide lower bar tried (sessions 15-20) found them and also found
caps and merged spots that the linkers then swapped. Here the lower bar (the detector's faint
search, ``Detections.faint``) is used only for a marker the other camera gives out at this
instant and this camera does not hold in this frame: the spot is searched along the other
camera's epipolar line around where this camera last had the marker (its lost track's
prediction, its last sighting, or its fitted grid point), and is taken only when

- exactly one faint spot lies within ``epipolar_px`` of that line in the window (two: say
  nothing), clear of every spot this camera tracks in this frame,
- the spot lies on no line of another marker the other camera gives out and this camera does
  not hold (:func:`rival_lines`), and no lost track of another number predicts it
  (:func:`claimed`): either could be that marker, and
- the pair's 3D point is one the marker can have reached from its last accepted position, and
  that position is at most ``MAX_DEPTH_AGE_S`` old (:func:`stale`; a marker never
  triangulated is placed by its grid point or last sighting alone).

The spot keeps the marker's number: it re-attaches the marker's lost track, or starts a track
with that number when this camera has none (numbered after the start, so a later pair that
contradicts it takes the number back). It is linked as a faint spot, so the pair checks
(:func:`~dempath_recon.tracking.pair_checks.verify`) give it out only after the tight
same-instant check against the other camera passes: no new track is left to the numbering
rules and the linker makes no choice.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import epipolar_distance, triangulate_pairs
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.linker import TrackFrame
from dempath_recon.tracking.state import MAX_DEPTH_AGE_S, StereoState, at_stamp

FloatArray = NDArray[np.float64]
PROBE_PX = 3.0  # probes along the line this far apart, each searching this radius [px]
SAME_SPOT_PX = 1.0  # two probes' spots this near are one spot [px]


def guide_points(state: StereoState, camera: str, held: set[int], stamp_s: float,
                 ) -> list[tuple[int, FloatArray, FloatArray, FloatArray | None]]:
    """The markers to look for in ``camera``'s frame at ``stamp_s``: each number the other
    camera gave out within a frame period that no track of ``camera`` holds in this frame
    (``held``), as ``(marker, the other camera's point at this instant (2,) px, the centre
    of the search (2,) px, the track's motion during the exposure (2,) px or None)``."""
    other = state.other(camera)
    tracker = state.trackers[camera]
    decay = tracker.config.velocity_decay
    exposure = tracker.config.exposure_s
    out: list[tuple[int, FloatArray, FloatArray, FloatArray | None]] = []
    for m, seen in sorted(state.latest[other].items()):
        if m in held or abs(seen[0] - stamp_s) > 1.0 / state.config.fps:
            continue
        track = next((t for t in tracker.tracks if t.marker == m), None)
        step = None
        if track is not None:
            if (track.track_id, m) in state.refused[camera]:
                continue
            centre = track.predict(stamp_s, decay)
            if exposure > 0:
                step = track.velocity * exposure * decay ** (stamp_s - track.last_stamp_s)
        elif m in state.latest[camera]:
            centre = state.latest[camera][m][1]
        elif m in state.grid_uv.get(camera, {}):
            centre = state.grid_uv[camera][m]
        else:
            continue
        out.append((m, at_stamp(state, other, m, seen, stamp_s), np.asarray(centre), step))
    return out


def line_spots(state: StereoState, camera: str, det: Detections, partner: FloatArray,
               centre: FloatArray, reach_px: float, step: FloatArray | None) -> FloatArray:
    """(k, 2) px: the distinct faint spots of ``det`` within ``reach_px`` of ``centre`` and
    ``epipolar_px`` of ``partner``'s epipolar line (``partner`` (2,) px in the other camera),
    searched by probes ``PROBE_PX`` apart along the line's stretch near ``centre``."""
    if det.faint is None:
        return np.zeros((0, 2))
    cam, other = state.cameras[camera], state.cameras[state.other(camera)]
    foot, direction = line_near(cam, other, partner, centre)
    n = int(np.ceil(reach_px / PROBE_PX))
    probes = foot + np.outer(np.arange(-n, n + 1) * PROBE_PX, direction)
    steps = None if step is None else np.repeat(step[None], len(probes), axis=0)
    found = det.faint(probes, PROBE_PX, steps)
    found = found[np.isfinite(found).all(axis=1)]
    if not len(found):
        return found
    found = found[np.linalg.norm(found - centre, axis=1) <= reach_px]
    on = epipolar_distance(other, cam, partner[None], found)[0] <= state.config.epipolar_px
    return distinct(found[on])


def line_near(cam: Camera, other: Camera, partner: FloatArray, centre: FloatArray,
              ) -> tuple[FloatArray, FloatArray]:
    """The point (2,) px of the epipolar line in ``cam`` of ``partner`` (2,) px in ``other``
    nearest ``centre`` (2,) px, and the line's unit direction (2,) there: the distance to the
    line grows linearly across it, so one step along its gradient reaches it (lens distortion
    bends the line by well under a pixel over a search window)."""
    probe = centre + np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    d = epipolar_distance(other, cam, partner[None], probe)[0]
    grad = np.array([d[1] - d[0], d[2] - d[0]])
    size = float(np.hypot(*grad))
    if size < 1e-9:
        return np.asarray(centre, np.float64), np.array([1.0, 0.0])
    normal = grad / size
    foot = centre - normal * d[0]
    check = epipolar_distance(other, cam, partner[None], foot[None])[0, 0]
    if check > d[0]:  # the gradient's sign is ambiguous at the line: step the other way
        foot = centre + normal * d[0]
    return np.asarray(foot, np.float64), np.array([-normal[1], normal[0]])


def distinct(spots: FloatArray) -> FloatArray:
    """(k, 2) ``spots`` (n, 2) px with the repeats (within ``SAME_SPOT_PX``) dropped."""
    keep: list[FloatArray] = []
    for p in spots:
        if all(np.linalg.norm(p - q) > SAME_SPOT_PX for q in keep):
            keep.append(p)
    return np.array(keep).reshape(-1, 2)


def recover_guided(state: StereoState, camera: str, det: Detections, tf: TrackFrame,
                   stamp_s: float, reach_px: float, events: list[str]) -> TrackFrame:
    """``tf`` with the markers recovered by a guided faint search appended (module
    docstring): each one's track re-attached or started with its number and marked as linked
    to a faint spot at ``stamp_s``. ``reach_px``: the search's radius around the centre."""
    held = {int(m) for m in tf.markers if m >= 0}
    tracker = state.trackers[camera]
    taken = np.asarray(tf.uv, np.float64).reshape(-1, 2)
    clear = state.config.detector.min_separation_px  # nearer, it is a tracked point's rim
    ids, markers, uvs = list(tf.track_ids), list(tf.markers), list(taken)
    for m, partner, centre, step in guide_points(state, camera, held, stamp_s):
        spots = line_spots(state, camera, det, partner, centre, reach_px, step)
        if len(spots) != 1:
            continue
        spot = spots[0]
        if len(uvs) and np.linalg.norm(np.array(uvs) - spot, axis=1).min() <= clear:
            continue
        if rival_lines(state, camera, m, spot, held, stamp_s) \
                or claimed(state, camera, m, spot, stamp_s):
            continue
        xyz, _ = triangulate_pairs(state.cameras[camera], state.cameras[state.other(camera)],
                                   spot[None], partner[None])
        if not state.positions.allows(m, stamp_s, xyz[0]) or stale(state, m, stamp_s):
            continue
        track = tracker.link_spot(m, spot, stamp_s, events)
        state.late_numbered[camera].add(track.track_id)
        state.counts[camera].recovered += 1
        events.append(f'{camera}: marker {m} recovered at {stamp_s:.3f} s: a faint spot on '
                      f"the other camera's line at ({spot[0]:.1f}, {spot[1]:.1f}) px")
        ids.append(track.track_id)
        markers.append(m)
        uvs.append(spot)
    k = len(ids) - len(tf.track_ids)
    if k == 0:
        return tf
    return tf._replace(track_ids=np.asarray(ids, np.int64),
                       markers=np.asarray(markers, np.int32),
                       uv=np.asarray(uvs, np.float64).reshape(-1, 2),
                       confidence=np.concatenate([tf.confidence, np.zeros(k)]))


def stale(state: StereoState, marker: int, stamp_s: float) -> bool:
    """Whether ``marker``'s last accepted 3D position is older than ``MAX_DEPTH_AGE_S``: it
    then no longer bounds where along the line the marker can be (the gate has grown to
    several marker pitches), so nothing places the spot. A marker never triangulated is not
    stale: its spot is placed by its grid point or last sighting alone."""
    known = state.positions.known.get(marker)
    return known is not None and stamp_s - known[0] > MAX_DEPTH_AGE_S + 1e-9


def claimed(state: StereoState, camera: str, marker: int, spot: FloatArray, stamp_s: float,
            ) -> bool:
    """Whether a lost track of ``camera`` numbered other than ``marker`` predicts ``spot``
    (2,) px within a marker's image diameter (``TrackerConfig.hold_rival_px`` as the
    two-camera tracker sets it; the grid gate if unset): the spot may be that marker come
    back."""
    tracker = state.trackers[camera]
    near = tracker.config.hold_rival_px or state.config.grid_gate_px
    decay = tracker.config.velocity_decay
    return any(t.lost and t.marker >= 0 and t.marker != marker
               and float(np.linalg.norm(t.predict(stamp_s, decay) - spot)) <= near
               for t in tracker.tracks)


def rival_lines(state: StereoState, camera: str, marker: int, spot: FloatArray,
                held: set[int], stamp_s: float) -> bool:
    """Whether ``spot`` (2,) px in ``camera`` lies within ``epipolar_px`` of the line of
    another marker the other camera gave out within a frame period and this camera does not
    hold in the frame (``held``): the spot could be that one (a neighbour's cap along the same
    line of sight; on a tuning look marker 6, hidden, was recovered on marker 7's cap and
    switched). The other camera's unnumbered tracks are not counted as rivals: with them the
    33 tuning looks kept 20 of the 25 recoveries within 3 px of their own marker (22 without
    them) and lost the gains of two looks (session 21)."""
    other = state.other(camera)
    period = 1.0 / state.config.fps
    points = [at_stamp(state, other, m, seen, stamp_s)
              for m, seen in state.latest[other].items()
              if m != marker and m not in held and abs(seen[0] - stamp_s) <= period]
    if not points:
        return False
    d = epipolar_distance(state.cameras[other], state.cameras[camera], np.array(points),
                          spot[None])[:, 0]
    return bool((d <= state.config.epipolar_px).any())
