"""Where one camera's projected grid sits in its image, told by the spots both cameras numbered.

A camera numbers the markers only it sees by its own projected grid (the grid shifted by the
image translation most grid points vote for, :func:`~dempath_recon.tracking.associate.
number_by_grid`). Where the view packs the grid's rows 13-15 px apart and a third of the
markers are not found (grey sand, light blue clay of little contrast), that vote can land one
pitch over: on a render of grey sand with light blue clay (hidden seed 33, JPEG 70) the front
camera's vote put its one-camera spots one row off (markers 1, 2 and 7 numbered 2, 3 and 8
from the first frame to the last) while the spots it had numbered with the side camera,
triangulated and matched to the grid in 3D, sat each at its own grid point, and the vote
numbered one of those one marker off too.

So the pairs check the vote (:func:`vote_contradicted`): where, among the spots both number,
more disagree than agree, the vote's numbers are not given, and the grid points later
numbering looks at (a marker this camera never saw, appearing alone at its fitted grid point)
are placed by the pairs instead (:func:`pair_shift`: the median of each numbered spot's offset
from its projected grid point, the grid's image shift plus that marker's own 5-10 px where the
bed moved it). Placing the grid by the pairs always, not only against a contradicted vote, cost
26 tuning looks 78.79 -> 78.12 % numbered right, switches 60 -> 66, wrong pairs 14 -> 17: the
vote, where the pairs do not contradict it, fits the one-camera spots better.

The other way round, a camera's own numbers check a pair (:func:`drop_contested`). The first
camera to send a frame numbers its spots alone, by its own grid fitted warily (no fit one pitch
over nearly as good), and gives them out; the other camera's first frame then numbers both
cameras' spots as pairs matched to the grid in 3D, and those numbers replace the first
camera's. With few spots found (faint light) two different markers can lie on each other's
epipolar lines and meet in 3D near a third marker's grid point: a ghost pair. On a tuning render
(hidden seed 21, light x0.5, 12 ms, JPEG 70) the side camera's own grid numbered its spot of
marker 9 rightly, a ghost of that spot and the front camera's spot of marker 13 met at grid
point 14, and both spots took 14 from the first frame to the last (26 wrong numbers, 9 3D
points 10-20 mm off, the look's 3D error 7.2 mm). A pair whose number the first camera's own
grid gave to another marker on the same spot is therefore not given: both spots wait for later
numbering (the epipolar lines, the pair numbering), unless the pairs contradict that camera's
grid as a whole (its vote slipped a pitch: the pairs are right).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import MarkerGrid

FloatArray = NDArray[np.float64]
MIN_ANCHORS = 2  # numbered spots needed to place the grid by the pairs


def pair_shift(camera: Camera, uv: FloatArray, numbers: NDArray[np.int32],
               grid: MarkerGrid) -> FloatArray | None:
    """(2,) px the image shift of ``camera``'s projected grid on which its (n, 2) spots ``uv``
    numbered by both cameras (``numbers``, -1: not numbered) sit at their grid points (the
    median of their offsets), or None when fewer than ``MIN_ANCHORS`` are numbered."""
    ids, xyz = grid.points()
    row = {int(m): k for k, m in enumerate(ids.tolist())}
    have = [i for i, m in enumerate(numbers.tolist()) if m >= 0 and m in row]
    if len(have) < MIN_ANCHORS:
        return None
    proj = np.asarray(camera.project(xyz), np.float64)  # type: ignore[attr-defined]
    off = uv[have] - proj[[row[int(numbers[i])] for i in have]]
    return np.asarray(np.median(off, axis=0), np.float64)


def vote_contradicted(voted: NDArray[np.int32], paired: NDArray[np.int32]) -> bool:
    """Whether one camera's own grid vote (``voted``: each spot's number by it, -1: none) is
    contradicted by the numbers its spots took with the other camera (``paired``): among the
    spots both number, more disagree than agree (the vote slipped a pitch; its numbers for the
    spots only this camera sees would be one marker off)."""
    both = (voted >= 0) & (paired >= 0)
    differ = int((voted[both] != paired[both]).sum())
    return differ > int(both.sum()) - differ


def drop_contested(mine: NDArray[np.int32], theirs: NDArray[np.int32],
                   provisional: NDArray[np.int32], camera: str, other: str,
                   events: list[str]) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    """The grid pairs' numbers without those ``other``'s own grid contradicts on a spot.

    Args:
        mine: (n,) the numbers the pairs give ``camera``'s spots (-1: none).
        theirs: (k,) the numbers they give ``other``'s spots (-1: none).
        provisional: (k,) the numbers ``other`` gave the same spots alone, by its own grid
            (-1: none).
        camera: the camera whose frame the pairs were fitted on (for the events).
        other: the camera numbered alone before.
        events: the frame's events (one is added per pair not given).

    Returns:
        ``(mine, theirs)`` with each pair whose number ``other``'s own grid gave its spot
        differently unnumbered in both cameras; unchanged when the pairs contradict that
        grid on most spots both number (:func:`vote_contradicted`: its fit slipped a pitch).
    """
    if vote_contradicted(provisional, theirs):
        return mine, theirs
    mine, theirs = mine.copy(), theirs.copy()
    for j in np.flatnonzero((theirs >= 0) & (provisional >= 0)
                            & (theirs != provisional)).tolist():
        m = int(theirs[j])
        mine[mine == m] = -1
        theirs[j] = -1
        events.append(f'{camera}: the pair numbered {m} at the grid fit is not given: {other} '
                      f'numbered its spot {int(provisional[j])} by its own grid')
    return mine, theirs


def drop_unclaimed_nearer(mine: NDArray[np.int32], theirs: NDArray[np.int32],
                          near_a: NDArray[np.int32], near_b: NDArray[np.int32], camera: str,
                          events: list[str]) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    """The grid pairs' numbers without those both cameras' own grids put elsewhere.

    A ghost pair (two different markers, each hidden in the other camera, whose spots lie on
    each other's epipolar lines and meet near a third marker's grid point) sits within the 3D
    gate like a right pair. But in each camera its spot lies nearest the image grid point of
    the marker it is, and no pair claims that marker (its partner is hidden). On a render of
    hidden seed 83 (cohesion) the side's spot of marker 2 (4.7 px from 2's fitted grid point,
    8.6 px from 7's) and the front's spot of 6 (2.6 and 8.9 px) met 9 mm from grid point 7 and
    took 7 in both cameras for the whole pass (21 wrong numbers, 4 3D points 5-20 mm off). A
    right pair may sit nearer another grid point in one camera (a view that packs the rows),
    or about as near another's in both (the bed moved it between grid points: a seed-65
    render's marker 14 sat 7.1 and 7.6 px from its own, 6.9 and 7.0 px from 9's and 13's), but
    on the tuned looks never clearly nearer an unclaimed one in both (the caller's margin).

    Args:
        mine: (n,) the numbers the pairs give ``camera``'s spots (-1: none).
        theirs: (k,) the numbers they give the other camera's spots (-1: none).
        near_a: (n,) the other marker whose fitted image grid point lies clearly nearer each
            of ``camera``'s spots than its pair's number's (-1: none, or not known).
        near_b: (k,) the same for the other camera's spots.
        camera: the camera whose frame the pairs were fitted on (for the events).
        events: the frame's events (one is added per pair not given).

    Returns:
        ``(mine, theirs)`` with such pairs unnumbered in both cameras.
    """
    claimed = set(mine[mine >= 0].tolist()) | set(theirs[theirs >= 0].tolist())
    mine, theirs = mine.copy(), theirs.copy()
    for i in np.flatnonzero(mine >= 0).tolist():
        m = int(mine[i])
        j = np.flatnonzero(theirs == m)
        if not len(j):
            continue
        a, b = int(near_a[i]), int(near_b[j[0]])
        if a < 0 or b < 0 or a in claimed or b in claimed:
            continue
        mine[i], theirs[j[0]] = -1, -1
        events.append(f'{camera}: the pair numbered {m} at the grid fit is not given: its '
                      f'spots lie nearest the grid points of markers {a} and {b}, which no pair '
                      'claims (a ghost of two markers each hidden in the other camera)')
    return mine, theirs
