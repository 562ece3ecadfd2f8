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

- the strongest faint spot of the stretch of that line within the search radius lies within
  ``epipolar_px`` of it, clear of every spot this camera tracks in this frame,
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
from dempath_recon.tracking.associate import (
    back_project,
    depth,
    epipolar_distance,
    project,
    triangulate_pairs,
)
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.linker import TrackFrame
from dempath_recon.tracking.state import MAX_DEPTH_AGE_S, StereoState, at_stamp

FloatArray = NDArray[np.float64]


def guide_points(state: StereoState, camera: str, held: set[int], stamp_s: float,
                 ) -> list[tuple[int, FloatArray, FloatArray]]:
    """The markers to look for in ``camera``'s frame at ``stamp_s``: each number the other
    camera gave out within a frame period that no track of ``camera`` holds in this frame
    (``held``) and whose 3D position is not stale (:func:`stale`), as ``(marker, the other
    camera's point at this instant (2,) px, the centre of the search (2,) px)``."""
    other = state.other(camera)
    tracker = state.trackers[camera]
    out: list[tuple[int, FloatArray, FloatArray]] = []
    for m, seen in sorted(state.latest[other].items()):
        if m in held or abs(seen[0] - stamp_s) > 1.0 / state.config.fps \
                or stale(state, m, stamp_s):
            continue
        track = next((t for t in tracker.tracks if t.marker == m), None)
        if track is not None:
            if (track.track_id, m) in state.refused[camera]:
                continue
            centre = track.predict(stamp_s, tracker.config.velocity_decay)
        elif m in state.latest[camera]:
            centre = state.latest[camera][m][1]
        elif m in state.grid_uv.get(camera, {}):
            centre = state.grid_uv[camera][m]
        else:
            continue
        out.append((m, at_stamp(state, other, m, seen, stamp_s), np.asarray(centre)))
    return out


def line_spot(state: StereoState, camera: str, det: Detections, partner: FloatArray,
              centre: FloatArray, reach_px: float) -> FloatArray | None:
    """(2,) px: the strongest faint spot of ``det`` on the stretch of ``partner``'s epipolar
    line (``partner`` (2,) px in the other camera) within ``reach_px`` of ``centre``, when it
    lies within ``epipolar_px`` of the line and ``reach_px`` of ``centre``; None otherwise (a
    stronger spot off the line hides it: say nothing). One search window around the stretch,
    spots only (no noise-bar fallback or streak: nine probes along the line with them cost
    more than the detection on the dusk looks; without them and in one window, 14 tuning
    looks numbered within 0.4 points of the probes' figures, the switches unchanged)."""
    if det.faint is None:
        return None
    cam, other = state.cameras[camera], state.cameras[state.other(camera)]
    foot, _ = line_near(cam, other, partner, centre)
    off = float(np.linalg.norm(foot - centre))
    if off > reach_px:  # the line passes farther than the search reaches
        return None
    spot = det.faint(foot[None], float(np.sqrt(reach_px ** 2 - off ** 2)), None, False)[0]
    if not np.isfinite(spot).all() or np.linalg.norm(spot - centre) > reach_px \
            or epipolar_distance(other, cam, partner[None], spot[None])[0, 0] \
            > state.config.epipolar_px:
        return None
    return np.asarray(spot, np.float64)


def line_near(cam: Camera, other: Camera, partner: FloatArray, centre: FloatArray,
              ) -> tuple[FloatArray, FloatArray]:
    """The point (2,) px of the epipolar line in ``cam`` of ``partner`` (2,) px in ``other``
    nearest ``centre`` (2,) px, and the line's unit direction (2,) there: two points of
    ``partner``'s line of sight 5 % either side of the depth the pair (``centre``,
    ``partner``) triangulates to, seen in ``cam`` (lens distortion bends the line by well
    under a pixel over a search window)."""
    xyz, _ = triangulate_pairs(cam, other, centre[None], partner[None])
    z = depth(other, xyz[0])
    if not z > 0:
        return np.asarray(centre, np.float64), np.array([1.0, 0.0])
    ends = project(cam, np.array([back_project(other, partner, f * z) for f in (0.95, 1.05)]))
    direction = (ends[1] - ends[0]) / max(float(np.linalg.norm(ends[1] - ends[0])), 1e-12)
    foot = ends[0] + float(np.dot(centre - ends[0], direction)) * direction
    return np.asarray(foot, np.float64), np.asarray(direction, np.float64)


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
    for m, partner, centre in guide_points(state, camera, held, stamp_s):
        spot = line_spot(state, camera, det, partner, centre, reach_px)
        if spot is None:
            continue
        if len(uvs) and np.linalg.norm(np.array(uvs) - spot, axis=1).min() <= clear:
            continue
        if rival_lines(state, camera, m, spot, held, stamp_s) \
                or claimed(state, camera, m, spot, stamp_s):
            continue
        xyz, _ = triangulate_pairs(state.cameras[camera], state.cameras[state.other(camera)],
                                   spot[None], partner[None])
        if not state.positions.allows(m, stamp_s, xyz[0]):
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
