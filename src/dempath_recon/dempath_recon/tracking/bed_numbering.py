"""Numbering over the whole pass by the bed's motion: a marker no numbered path places is
placed by where the sand around it went, and an unnumbered piece of track that follows that
place, clearly better than any rival, takes its number.

The steps before (:mod:`~dempath_recon.tracking.whole_pass`,
:mod:`~dempath_recon.tracking.piece_numbering`) number a stretch of track by how it continues
its marker's own numbered path. What they leave is mostly a marker with no such path in that
camera: on 26 tuning looks (session 25's census, 867 found-but-unnumbered marker-frames) 43 %
belong to a marker that camera never numbered in the whole pass, most of them covered at the
grid fit and coming out mid-pass in the tool's column. Sand moves as a continuum: a covered
marker goes where the markers around it go. So, at the pass's end:

1. **The bed's displacement field** (:class:`~dempath_recon.tracking.bed_field.BedField`):
   each marker placed at each instant from its neighbours' numbered 3D paths, with the
   field's spread there.
2. **Units**: each camera's unnumbered pieces of track (as
   :func:`~dempath_recon.tracking.piece_numbering.unnumbered_pieces`), paired into 3D pieces
   where both cameras have one (one assignment on the epipolar distance, with its margin).
3. **One assignment** of units to the markers none of the unit's cameras gives out over its
   stretch, on the median distance in spreads of its points from the marker's predicted
   points (:func:`~dempath_recon.tracking.bed_field.spreads_off`). A unit takes a marker only
   within ``GATE_SPREADS`` spreads, when every rival is ``ODDS`` times less likely
   (:func:`odds_clear`: every other marker for it, every other time-overlapping unit for
   that marker, and the markers its cameras give out then,
   :func:`~dempath_recon.tracking.bed_field.nearest_given`), its own 2D track carries no
   other number right beside it
   (:func:`~dempath_recon.tracking.piece_numbering.track_bounds`), and, a piece alone, no
   other marker's own point lies within a diameter of it
   (:func:`~dempath_recon.tracking.piece_numbering.touched`: one camera cannot tell two
   touching markers apart).
4. Never a number its frame gives out, nor one a rule withheld there on evidence
   (:func:`~dempath_recon.tracking.joint_fill.withheld`); ``ROUNDS`` rounds, each with the
   field of the numbers the round before gave.

Off by default (``StereoTrackConfig.bed_numbering``): on 52 tuning looks it numbered 0.02
points more right, no switch added; on the held-apart seed 0.15 (docs/figures.md, session 25).
Since session 26 it runs after the joint fill (a spot its marker's own 3D path fills is that
marker's) on a sheared field (``sheared``:
:data:`~dempath_recon.tracking.bed_field.SHEAR_ACROSS`): 79 tuning looks 88.51 -> 88.73 %
(number25's form 88.53), but one switch added on a tuning look and one on the held-apart
seed, and 0.6 ms of CPU a frame: still off.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.bed_field import (
    GATE_SPREADS,
    SHEAR_ACROSS,
    SHEAR_ALONG,
    SIGMA_PITCH,
    BedField,
    nearest_given,
    rest_points,
    spreads_off,
)
from dempath_recon.tracking.joint_fill import withheld
from dempath_recon.tracking.piece_numbering import (
    pair_pieces,
    touched,
    track_bounds,
    unnumbered_pieces,
)
from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.trajectories import marker_histories
from dempath_recon.tracking.whole_pass import Assignment, Pass, marker_points_3d

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
ODDS = 20.0  # a rival (another marker for the unit, another unit for the marker) must be this
# many times less likely (Gaussian, one spread as sigma: z2^2 - z^2 >= 2 ln ODDS) [ratio]
ROUNDS = 2  # rounds, each with the field of the numbers the round before gave


def by_bed(ps: Pass, field: BedField, frames: Sequence[PixelFrame],
           track_ids: Sequence[NDArray[np.int64]], diameter_px: dict[str, float],
           markers: list[int]) -> list[Assignment]:
    """The units numbered by one assignment on their shares from the bed's field, the clear
    ones (module docstring, step 3)."""
    from scipy.optimize import linear_sum_assignment

    pieces = {c: unnumbered_pieces(frames, track_ids, c, ps.fps) for c in sorted(ps.cameras)}
    pairs, alone = pair_pieces(ps, pieces)
    units = pairs + alone
    if not units or not markers:
        return []
    cost = np.full((len(units), len(markers)), np.inf)
    takes: dict[tuple[int, int], tuple[NDArray[np.bool_], ...]] = {}
    for i, u in enumerate(units):
        for j, m in enumerate(markers):
            cost[i, j], takes[i, j] = spreads_off(ps, field, *u, m)
    allowed = cost <= GATE_SPREADS
    for i, j in zip(*np.nonzero(allowed), strict=True):
        u, m = units[int(i)], markers[int(j)]
        bounds = frozenset().union(*(track_bounds(frames, track_ids, p, ps.fps)
                                     for p in u.pieces))
        allowed[i, j] = not bounds - {m} and not (
            u.fit is None and touched(ps, u.pieces[0], m, diameter_px))
    if not allowed.any():
        return []
    rows, cols = linear_sum_assignment(np.where(allowed, cost, 1e6))
    spans = [u.span() for u in units]
    return [Assignment(markers[c], units[r].pieces, takes[r, c], 'bed')
            for r, c in zip(rows.tolist(), cols.tolist(), strict=True)
            if allowed[r, c] and odds_clear(cost, spans, r, c, np.inf)
            and odds_clear(cost, spans, r, c, nearest_given(ps, field, units[r].pieces))]


def odds_clear(z: FloatArray, spans: list[tuple[float, float]], row: int, col: int,
               given: float) -> bool:
    """Whether unit ``row`` is clearly marker ``col``: every other marker's distance for it,
    every other time-overlapping unit's for that marker (``z``: in spreads), and the unit's
    distance from the markers its cameras give out then (``given``:
    :func:`~dempath_recon.tracking.bed_field.nearest_given`) is at least ``ODDS`` times less
    likely, the spread taken as a Gaussian's sigma (z2^2 - z^2 >= 2 ln ``ODDS``). A ratio of
    distances is no margin when both lie well within the spread (on a tuning look a piece
    0.5 spreads from one marker and 1.1 from its neighbour was the neighbour)."""
    best = z[row, col]
    t0, t1 = spans[row]
    over = [r for r, (a, b) in enumerate(spans) if r != row and a <= t1 and b >= t0]
    others = np.concatenate([np.delete(z[row], col), z[over, col], [given]])
    others = others[np.isfinite(others)]
    return not len(others) or bool(others.min() ** 2 - best ** 2 >= 2 * np.log(ODDS))


def number_by_bed(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                  cameras: dict[str, Camera], grid_uv: dict[str, dict[int, FloatArray]],
                  layout: dict[int, FloatArray], diameter_px: dict[str, float],
                  epipolar_px: float, fps: float, sheared: bool = False,
                  ) -> tuple[list[PixelFrame], int]:
    """The pass's frames (both cameras, as they would be given out; ``track_ids`` (k,) each
    point's 2D track) with unnumbered pieces of track numbered by the bed's motion (module
    docstring), and how many points got a number.

    Args:
        frames: every frame of the pass.
        track_ids: per frame, (k,) the track of each point.
        cameras: ``{name: camera}`` of the two cameras.
        grid_uv: camera -> marker -> (2,) px, the fitted grid (the markers' rest points).
        layout: marker -> (3,) m, the grid's layout (world frame): a marker no camera fitted.
        diameter_px: camera -> a marker's diameter in its images [px].
        epipolar_px: the pipeline's ``epipolar_px``: a pair's line distance gate [px].
        fps: the frame rate [1/s].
        sheared: weigh the field's neighbours by their rest gaps across and along the travel
            (``SHEAR_ACROSS``, ``SHEAR_ALONG`` pitches), not by their rest distance.
    """
    out, given = list(frames), 0
    across, along = (SHEAR_ACROSS, SHEAR_ALONG) if sheared else (SIGMA_PITCH, SIGMA_PITCH)
    if not out or len(cameras) != 2:
        return out, 0
    names = sorted(cameras)
    rest = rest_points(grid_uv, cameras, layout)
    markers = sorted(rest)
    for _ in range(ROUNDS):
        ps = Pass(cameras, {c: marker_histories(out, c) for c in names},
                  marker_points_3d(out, cameras, fps), grid_uv,
                  min(f.stamp_s for f in out), epipolar_px, fps)
        field = BedField(ps.own_3d, rest, fps, ps.start_s, across, along)
        found = by_bed(ps, field, out, track_ids, diameter_px, markers)
        out, n = _give(out, found)
        given += n
        if not n:
            break
    return out, given


def _give(frames: list[PixelFrame], found: list[Assignment]) -> tuple[list[PixelFrame], int]:
    """``frames`` with each assignment's marker given to its pieces' points that may take it,
    but where the frame gives it out or a rule withheld it there; and how many got it."""
    out = [f.markers.copy() for f in frames]
    given = 0
    for a in found:
        for piece, ok in zip(a.tracks, a.shared, strict=True):
            for i, k in piece.where[ok].tolist():
                if a.marker not in out[i] and out[i][k] < 0 and not withheld(frames[i],
                                                                             a.marker):
                    out[i][k] = a.marker
                    given += 1
        LOG.info('bed: %s numbered %d', '+'.join(
            f'{p.camera} track {p.track_id} at {p.times[0]:.3f}-{p.times[-1]:.3f} s'
            for p in a.tracks), a.marker)
    return [f._replace(markers=m) for f, m in zip(frames, out, strict=True)], given
