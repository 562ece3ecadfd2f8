"""A grid pair one of whose spots is another marker, seen by that camera alone: its number is
not given to that spot.

At the grid fit (:func:`~dempath_recon.tracking.grid_pairs.pairs_by_grid`) two markers that lie
on one line of sight of camera a, each hidden in the other camera, can pair as one: camera a
sees the front one (m'), camera b only the one behind it (m), and a's spot of m' lies on the
epipolar line of b's spot of m, so the pair meets in 3D near m's grid point and both spots take
m. Camera b's spot is m (it sits at m's image grid point and near no other); camera a's is m'.
On a cohesive dusk render (hidden seed 131, light x0.3, 12 ms) the front's spot of marker 1
(69 % visible; marker 2 behind it, 42 %) paired with the side's spot of marker 2 (marker 1 26 %
visible there): the pair met 6.8 mm from grid point 2, 3.0 px off the epipolar line, and the
front's spot took 2 for the whole pass; the side's track of 2 later followed marker 1 as well
(40 wrong numbers, 23 3D points more than 5 mm off, up to 46 mm; the look's 3D error 8.6 mm).

:func:`~dempath_recon.tracking.pair_anchor.drop_unclaimed_nearer` drops a ghost of two
markers (each camera's spot nearest the grid point of a marker no pair claims). This is the
half of it: only camera a's spot lies clearly nearer an unclaimed marker's image grid point
(``near``, :func:`~dempath_recon.tracking.numbering.grid_rival`), while camera b's spot lies
nearest its own. That alone is weak evidence: a right pair's spot sits nearer another grid
point in one camera where the view packs the rows (dropping on it alone, four tuning looks lost
3-13 % of their numbered-right marker-frames and one gained 10 switches). So the pair must also
lie in the outer 40 % of the epipolar gate (``EPIPOLAR_SHARE``), where two markers meet by
chance and a right pair seldom lies. A wrong number is worse than none: a's spot is left
unnumbered (and its track refused the number by the caller, as for every pair not given), to
be numbered later by the epipolar lines or as a pair; b's spot keeps it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
EPIPOLAR_SHARE = 0.6  # a half ghost's pair lies at least this share of the epipolar gate off
# the line: a pair of two markers lies anywhere within the gate, a right pair within its two
# spots' localisation errors (383 right pairs at the grid fits of 51 tuning looks: 95 % within
# 1.9 px, 99 % within 2.4 px of a 4 px gate; the traced half ghosts 3.0 and 4.0 px; a right
# pair of a seed-83 look, its front spot merged with a half-buried neighbour, 2.04 px)


def drop_half_ghosts(mine: NDArray[np.int32], theirs: NDArray[np.int32],
                     near_a: NDArray[np.int32], near_b: NDArray[np.int32],
                     epipolar: FloatArray, gate_px: float, camera: str, other: str,
                     events: list[str]) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    """The grid pairs' numbers without the spot of each pair that lies nearer an unclaimed
    marker's image grid point in its camera alone.

    Args:
        mine: (n,) the numbers the pairs give ``camera``'s spots (-1: none).
        theirs: (k,) the numbers they give ``other``'s spots (-1: none).
        near_a: (n,) the other marker whose fitted image grid point lies clearly nearer each
            of ``camera``'s spots than its pair's number's (-1: none, or not known).
        near_b: (k,) the same for ``other``'s spots.
        epipolar: (n, k) px each pair's distance from the epipolar line.
        gate_px: the pairs' epipolar gate [px] (``StereoTrackConfig.epipolar_px``).
        camera: the camera whose frame the pairs were fitted on.
        other: the other camera.
        events: the frame's events (one is added per spot not numbered).

    Returns:
        ``(mine, theirs)`` with such spots unnumbered (their partners keep the number).
    """
    claimed = set(mine[mine >= 0].tolist()) | set(theirs[theirs >= 0].tolist())
    out_a, out_b = mine.copy(), theirs.copy()
    for nums, near, o_nums, o_near, cam in ((mine, near_a, theirs, near_b, camera),
                                            (theirs, near_b, mine, near_a, other)):
        out = out_a if cam == camera else out_b
        for i in np.flatnonzero(nums >= 0).tolist():
            m = int(nums[i])
            j = np.flatnonzero(o_nums == m)
            rival = int(near[i])
            if not len(j) or rival < 0 or rival in claimed or int(o_near[j[0]]) >= 0:
                continue
            off = epipolar[i, j[0]] if cam == camera else epipolar[j[0], i]
            if off < EPIPOLAR_SHARE * gate_px:
                continue
            out[i] = -1
            events.append(f'{cam}: its spot of the pair numbered {m} at the grid fit is not '
                          f'numbered: it lies nearest the grid point of marker {rival}, which '
                          'no pair claims, and the other camera sees only one marker there')
    return out_a, out_b
