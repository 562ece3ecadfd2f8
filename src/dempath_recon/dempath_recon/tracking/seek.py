"""Faint spots sought where the other camera gives out a marker this camera holds no track of.

At dusk (light x0.3, a 12-16 ms shutter) many markers stay under the detector's threshold in
one camera for a whole look: their filtered chroma peaks at 0.05-0.15 against a threshold of
0.15 (the twin's carriage rig at dusk, session 18: 71 of 428 visible marker-frames never
detected, in whole columns: a marker missing in every frame), while the other camera finds and
numbers them. The linker's faint search (``Detections.faint``, a lower bar beside a track's
prediction, or one set by the window's own noise where it is dim) helps only a marker that
already has a numbered track; a marker never found has none. A lower bar over the whole frame
finds spots in the sand (sessions 15 and 17: more wrong pairs).

The other camera's sighting says where to look: its line of sight, at the depth the bed has
carried the marker to (:func:`~dempath_recon.tracking.state.carried_point`: its last 3D
position moved as its neighbours moved, or its fitted grid point), projected into this camera.
The faint search runs there only, and a spot it finds is added to the frame's detections as an
ordinary unnumbered spot: its number comes, as any new track's, from the pair numbering and
its checks (the epipolar line, the 3D position; :mod:`~dempath_recon.tracking.pair_numbering`,
:mod:`~dempath_recon.tracking.pair_checks`), never from the search itself.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import back_project, depth, project
from dempath_recon.tracking.detect import SOUGHT_DIM_SUM_DN, Detections
from dempath_recon.tracking.state import RECENT_S, StereoState, carried_point

FloatArray = NDArray[np.float64]
SEEK_RADIUS_PX = 3.0  # farthest a sought spot may lie from where it is sought [full-size px]:
# the projections were 1-3 px from the markers' true centres on the twin's carriage rig at dusk
# (session 18); 4 px took a neighbour's edge on r21_dusk (4 switches, 4 wrong-pair points on 29
# tuning looks, 0 at 3 px) and 6 px more (r21_dusk16: 12 switches)
SEEK_UNSEEN = True  # also seek a marker neither camera holds, at its carried place (at a 4 px
# radius, 29 tuning looks: without 78.41 % numbered right, 69 switches; with 78.92 %, 55)
CLEAR_PX = 12.0  # no search where a spot of the frame lies this near the projection [px]:
# that spot is the marker's (numbered or not), or a neighbour's the search must not take


def sought_points(state: StereoState, camera: str, stamp_s: float,
                  ) -> tuple[list[int], FloatArray]:
    """The markers ``camera`` holds no track of (numbered, running or lost) and where to look
    for each: (markers, (k, 2) px). A marker the other camera gave out within ``RECENT_S``
    from a steady track: on that sighting's line of sight at the depth the bed carried it to;
    with
    ``SEEK_UNSEEN`` also a marker neither camera holds: its carried place itself."""
    held = {t.marker for t in state.trackers[camera].tracks if t.marker >= 0}
    other = state.other(camera)
    held_there = {t.marker for t in state.trackers[other].tracks if t.marker >= 0}
    # a sighting leads the search only from a track that kept its marker: not lost, not just
    # re-attached or linked to a faint spot (a track that jumped onto a neighbour would lead
    # this camera to that neighbour too, and the pair would agree on the wrong marker)
    steady = {t.marker for t in state.trackers[other].tracks
              if t.marker >= 0 and not t.lost and not t.back_unchecked
              and (t.faint_stamp is None or stamp_s - t.faint_stamp > RECENT_S)
              and t.marker not in state.pending[other]}
    cam, ocam = state.cameras[camera], state.cameras[other]
    numbers, _ = state.config.grid.points()
    markers, points = [], []
    for m in sorted(int(n) for n in numbers):
        if m in held:
            continue
        sighting = state.latest[other].get(m)
        recent = sighting is not None and abs(stamp_s - sighting[0]) <= RECENT_S \
            and m in steady
        if not recent and (m in held_there or not SEEK_UNSEEN):
            continue
        placed = carried_point(state, m, stamp_s)
        if placed is None:
            continue
        xyz = placed[0]
        if recent and sighting is not None:
            z = depth(ocam, placed[0])
            if not z > 0:
                continue
            xyz = back_project(ocam, np.asarray(sighting[1], np.float64), z)
        markers.append(m)
        points.append(project(cam, np.asarray(xyz, np.float64).reshape(1, 3))[0])
    return markers, np.asarray(points, np.float64).reshape(-1, 2)


def seek_markers(state: StereoState, camera: str, stamp_s: float,
                 det: Detections) -> Detections:
    """``det`` with the faint spots found where the other camera's markers this camera has no
    track of should be (:func:`sought_points`), each added as an unnumbered spot of
    confidence 0; ``det`` itself when there is nothing to seek or nothing is found."""
    if det.faint is None or camera not in state.grid_uv:  # not into this camera's grid fit
        return det
    _, points = sought_points(state, camera, stamp_s)
    if len(points) and len(det.uv):
        gap = np.linalg.norm(points[:, None] - det.uv[None], axis=2).min(axis=1)
        points = points[gap > CLEAR_PX]
    if not len(points):
        return det
    spots = det.faint(points, SEEK_RADIUS_PX, None, SOUGHT_DIM_SUM_DN)
    spots = spots[np.isfinite(spots).all(axis=1)]
    if not len(spots):
        return det
    spots = np.unique(spots, axis=0)  # two sightings that found one spot add it once
    return add_spots(det, spots)


def add_spots(det: Detections, spots: FloatArray) -> Detections:
    """``det`` with ``spots`` (k, 2) px appended: confidence 0, a lone marker's size (the
    frame's median spot, 0 when it has none), not crowded, not parted, centred as found."""
    k = len(spots)
    size = float(np.median(det.size_px)) if len(det.size_px) else 0.0
    return det._replace(
        uv=np.vstack([det.uv, spots]), confidence=np.concatenate([det.confidence, np.zeros(k)]),
        size_px=np.concatenate([det.size_px, np.full(k, size)]),
        crowded=None if det.crowded is None else np.concatenate([det.crowded, np.zeros(k, bool)]),
        centre=None if det.centre is None else np.vstack([det.centre, spots]),
        parted=None if det.parted is None else np.concatenate([det.parted, np.zeros(k, bool)]))


def bar_sought(state: StereoState, camera: str, barred: dict[int, NDArray[np.bool_]],
               own: int, total: int) -> dict[int, NDArray[np.bool_]]:
    """``barred`` (track id -> (total,) detections it may not link to) with the sought spots
    (detections ``own`` to ``total``) barred to every numbered track of ``camera``: each was
    sought for a marker this camera holds no track of, so a numbered track that took it (a
    lost one re-attaching within its wider gate) would take another marker's spot."""
    if total <= own:
        return barred
    out = dict(barred)
    for track in state.trackers[camera].tracks:
        if track.marker < 0:
            continue
        mask = np.array(out.get(track.track_id, np.zeros(total, bool)), bool)
        mask[own:] = True
        out[track.track_id] = mask
    return out
