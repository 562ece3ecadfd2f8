"""The bed's displacement field over a pass: where the sand carried a marker that no numbered
path places, from where the markers around it went, and how far that may be off.

Sand moves as a continuum: a covered marker goes where the markers around it go
(``MarkerPositions.carried`` applies this frame by frame from the three nearest neighbours).
Over the whole pass (at ``flush``) every numbered marker's 3D path is known, so
:class:`BedField` places a marker at any instant: its rest point (the fitted grid
triangulated, :func:`rest_points`) or its own nearest numbered 3D point (an anchor), moved by
the Gaussian-weighted mean of its neighbours' displacements since (weights by the distance
between rest points, ``SIGMA_PITCH`` grid pitches; or, the bed sheared, by the rest gaps
across and along the travel, ``SHEAR_ACROSS`` and ``SHEAR_ALONG`` pitches: the tool pushes
its own column far more than the next, the whole column alike), and says how far it may be
off: the weighted standard deviation of those displacements plus ``FLOOR_M`` (the spread).
Near the tool the field is far from uniform (the tool's column is pushed 50-140 mm, the far
column a few mm), and the spread says so. On 8 tuning looks' true paths (session 25) the error was
within 2.5 spreads nine times in ten and 2.0 spreads 99 times in 100.

:func:`spreads_off` scores a unit of track (one camera's piece, or both cameras' paired in 3D)
against a marker's predicted points; :func:`prefers_other` says when the field speaks against
a number another step would give.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import project, triangulate_pairs
from dempath_recon.tracking.trajectories import interpolate_history
from dempath_recon.tracking.whole_pass import (
    MEDIAN_SHARE,
    MIN_SHARED,
    START_FRAMES,
    PairFit,
    Pass,
    Track,
    lacks,
)

FloatArray = NDArray[np.float64]
SIGMA_PITCH = 1.0  # the neighbours' weight falls as a Gaussian of their rest distance with
# this many grid pitches as its sigma (one pitch: the ring of nearest markers leads; on 8
# tuning looks' true paths 0.6 and 1.4 pitches gave the same error, 1.0 the best-calibrated)
FLOOR_M = 0.004  # the spread's floor [m]: the grid fit's and the 3D points' own error, and
# the sand's grain (a few mm) where the neighbours all move alike
GATE_SPREADS = 2.5  # a piece may be the marker within this many spreads of its predicted
# point (the true paths: the error within 2.5 spreads nine times in ten)
SHEAR_ACROSS = 0.35  # the sheared bed's weight: the neighbours' sigma across the travel (X)
# [grid pitches]: the tool's column is pushed 50-140 mm along the travel and the column beside
# it 5-60 mm (session 25's true paths), so a marker across goes elsewhere; on 10 tuning looks'
# true paths (heldout27) 0.35 named 532 of 899 hidden, seen marker-instances, 1.0 named 361
SHEAR_ALONG = 2.0  # and along the travel (Z) [grid pitches]: the heap ahead of the tine
# carries the whole column alike (0.5 / 1.5 named 430 there; 0.35 / 2.0 numbered the most on
# 67 tuning looks with no switch added)
MIN_NEIGHBOURS = 3  # numbered markers with a 3D point at an instant needed to place another


def rest_points(grid_uv: dict[str, dict[int, FloatArray]], cameras: dict[str, Camera],
                layout: dict[int, FloatArray]) -> dict[int, FloatArray]:
    """Marker -> (3,) m: its rest point, the fitted grid point of both cameras triangulated;
    a marker only one camera (or none) fitted: its layout point (``layout``, world frame)
    moved by the median offset of the triangulated points from theirs."""
    a, b = sorted(cameras)
    both = sorted(set(grid_uv.get(a, {})) & set(grid_uv.get(b, {})))
    out: dict[int, FloatArray] = {}
    if both:
        xyz, _ = triangulate_pairs(cameras[a], cameras[b],
                                   np.array([grid_uv[a][m] for m in both]),
                                   np.array([grid_uv[b][m] for m in both]))
        out = {m: np.asarray(p, np.float64) for m, p in zip(both, xyz, strict=True)}
    known = [m for m in out if m in layout]
    shift = np.median([out[m] - layout[m] for m in known], axis=0) if known else np.zeros(3)
    for m, p in layout.items():
        out.setdefault(m, np.asarray(p + shift, np.float64))
    return out


class Placed(NamedTuple):
    """A marker's predicted 3D points: ``xyz`` (k, 3) m and ``spread`` (k,) m (NaN where the
    field cannot place it)."""

    xyz: FloatArray
    spread: FloatArray


class BedField:
    """The bed's displacement field over the pass, from the numbered markers' 3D paths.

    Args:
        own_3d: marker -> (times (k,) s, (k, 3) m): its numbered 3D points.
        rest: marker -> (3,) m: its rest point (:func:`rest_points`).
        fps: the frame rate [1/s] (a point is read within 1.5 frame periods).
        start_s: the pass's first stamp [s]: a marker whose numbered 3D path starts within
            ``START_FRAMES`` frames of it rests where that path starts (measured; the fitted
            grid's point lies 2-11 mm off a marker's centre on a tuning look, most in height:
            a half-buried marker sits below the surface the grid lies on). None: the grid's.
        across: the neighbours' weight's sigma across the travel (X) [grid pitches].
        along: and along the travel (Z) [grid pitches]; equal: by their 3D rest distance.
    """

    def __init__(self, own_3d: dict[int, tuple[FloatArray, FloatArray]],
                 rest: dict[int, FloatArray], fps: float, start_s: float | None = None,
                 across: float = SIGMA_PITCH, along: float = SIGMA_PITCH) -> None:
        self.own_3d = own_3d
        self.fps = fps
        self.across = across
        self.along = along
        self.rest = dict(rest)
        for m, (times, xyz) in own_3d.items():
            if start_s is not None and m in rest and len(times) \
                    and times[0] - start_s <= (START_FRAMES + 0.5) / fps:
                self.rest[m] = xyz[0]
        pts = np.array(list(rest.values()))
        gaps = np.linalg.norm(pts[:, None] - pts[None], axis=2) if len(pts) > 1 else None
        if gaps is not None:
            np.fill_diagonal(gaps, np.inf)
        self.pitch_m = float(np.median(gaps.min(axis=1))) if gaps is not None else 0.025
        self._ids = [m for m in sorted(own_3d) if m in self.rest]
        # times (as bytes) -> every marker's displacements then, and marker -> its placing
        # (a unit is scored against every marker at its own stamps: computed once)
        self._moved: dict[bytes, FloatArray] = {}
        self._placed: dict[tuple[int, bytes], Placed] = {}

    def displacements(self, times: FloatArray, skip: int) -> tuple[list[int], FloatArray]:
        """The markers (but ``skip``) with a rest point and numbered 3D points, and their
        displacements from rest at ``times``: (n, k, 3) m (NaN where none within 1.5 frame
        periods)."""
        key = times.tobytes()
        if key not in self._moved:
            out = np.full((len(self._ids), len(times), 3), np.nan)
            for n, m in enumerate(self._ids):
                out[n] = points_at(self.own_3d[m], times, 1.5 / self.fps) - self.rest[m]
            self._moved[key] = out
        keep = [n for n, m in enumerate(self._ids) if m != skip]
        return [self._ids[n] for n in keep], self._moved[key][keep]

    def place(self, marker: int, times: FloatArray) -> Placed:
        """Where the bed carried ``marker`` at ``times`` (k,) s: from its own numbered 3D
        point nearest in time (an anchor) or else its rest point, moved by the weighted mean
        of its neighbours' displacements since then; the spread is the weighted standard
        deviation of those displacements plus ``FLOOR_M``."""
        key = (marker, times.tobytes())
        if key not in self._placed:
            self._placed[key] = self._place(marker, times)
        return self._placed[key]

    def _place(self, marker: int, times: FloatArray) -> Placed:
        """:meth:`place`, computed."""
        nan = np.full((len(times), 3), np.nan)
        if marker not in self.rest:
            return Placed(nan, np.full(len(times), np.nan))
        ids, disp = self.displacements(times, marker)
        base = self.rest[marker]
        start: FloatArray = np.zeros((len(ids), len(times), 3))
        own = self.own_3d.get(marker)
        if own is not None and len(own[0]):
            k = np.abs(own[0][None, :] - times[:, None]).argmin(axis=1)  # nearest own point
            base = own[1][k]
            start = self.displacements(own[0][k], marker)[1]
        if not ids:
            return Placed(nan, np.full(len(times), np.nan))
        gap = np.array([self.rest[m] - self.rest[marker] for m in ids])
        scaled = np.linalg.norm(gap, axis=1) / self.across if self.across == self.along \
            else np.hypot(gap[:, 0] / self.across, gap[:, 2] / self.along)
        weight = np.exp(-0.5 * (scaled / self.pitch_m) ** 2)
        moved = disp - start  # (n, k, 3)
        ok: NDArray[np.bool_] = np.asarray(np.isfinite(moved).all(axis=2), bool)
        w = np.where(ok, weight[:, None], 0.0)
        total = w.sum(axis=0)
        enough: NDArray[np.bool_] = np.asarray(ok.sum(axis=0) >= MIN_NEIGHBOURS, bool)
        w = w / np.where(total > 0, total, 1.0)
        filled = np.where(ok[..., None], moved, 0.0)
        mean = (w[..., None] * filled).sum(axis=0)
        var = (w * ((filled - mean[None]) ** 2).sum(axis=2)).sum(axis=0)
        xyz = np.where(enough[:, None], base + mean, np.nan)
        spread = np.where(enough, np.sqrt(var) + FLOOR_M, np.nan)
        return Placed(np.asarray(xyz, np.float64), np.asarray(spread, np.float64))


def points_at(hist: tuple[FloatArray, FloatArray], times: FloatArray, max_gap_s: float,
              ) -> FloatArray:
    """(k, d): a path (times (n,) s, points (n, d)) at ``times`` (k,) s, linear between two
    samples at most ``max_gap_s`` apart, the end sample within half of it beyond the ends;
    NaN elsewhere (the two cameras do not expose at one instant)."""
    t_own, p_own = hist
    out = np.full((len(times), p_own.shape[1]), np.nan)
    if not len(t_own):
        return out
    k = np.clip(np.searchsorted(t_own, times), 1, max(len(t_own) - 1, 1))
    inside = (times >= t_own[0]) & (times <= t_own[-1]) & (len(t_own) > 1)
    if len(t_own) > 1:
        inside &= (t_own[k] - t_own[k - 1]) <= max_gap_s
        for i in range(p_own.shape[1]):
            out[inside, i] = np.interp(times[inside], t_own, p_own[:, i])
    for end in (0, -1):
        near = ~inside & (np.abs(times - t_own[end]) <= 0.5 * max_gap_s)
        out[near] = p_own[end]
    return out


def spreads_off(ps: Pass, field: BedField, pieces: tuple[Track, ...],
                shared: tuple[NDArray[np.bool_], ...], fit: PairFit | None, marker: int,
                ) -> tuple[float, tuple[NDArray[np.bool_], ...]]:
    """How far a unit (``pieces``: one camera's, or both paired in 3D with ``fit``, the first
    against the second; ``shared``: the points of each that may take a number) lies from
    ``marker``'s predicted points: the median over its points of the distance in spreads
    (inf: a camera of the unit gives the marker out over its stretch, or the field cannot
    place it), and the points of each piece that may take it. A 3D unit in 3D; a piece alone
    projected into its camera, the spread at the predicted point's depth, unless the other
    camera's numbered points of the marker cover its stretch: then it must lie on their
    epipolar lines, and its 3D points are scored."""
    for p in pieces:
        if not lacks(ps.own_2d[p.camera], marker, p.times, ps.fps):
            return np.inf, shared
    if fit is not None:
        ok = shared[0]
        return _share_3d(field, marker, pieces[0].times[ok], fit.xyz[ok]), shared
    piece = pieces[0]
    theirs = ps.own_2d[ps.other(piece.camera)].get(marker)
    other_uv = None if theirs is None else interpolate_history(theirs, piece.times,
                                                                1.5 / ps.fps)
    fit = None if other_uv is None else ps.fit(piece, other_uv)
    if fit is not None:  # the other camera gives it out meanwhile: on its lines, in 3D
        if not fit.fits:
            return np.inf, shared
        ok = fit.checked
        return _share_3d(field, marker, piece.times[ok], fit.xyz[ok]), (fit.checked,)
    placed = field.place(marker, piece.times)
    cam = ps.cameras[piece.camera]
    have = np.isfinite(placed.spread)
    if have.sum() < MIN_SHARED:
        return np.inf, shared
    at = project(cam, placed.xyz[have])
    spread_px = placed.spread[have] * _px_per_m(cam, placed.xyz[have])
    d = np.linalg.norm(piece.uv[have] - at, axis=1) / spread_px
    return float(np.median(d)), shared


def _share_3d(field: BedField, marker: int, times: FloatArray, xyz: FloatArray) -> float:
    """The median distance of 3D points (k, 3) m at ``times`` from the marker's predicted
    points, in spreads (inf: fewer than ``MIN_SHARED`` placed)."""
    placed = field.place(marker, times)
    have = np.isfinite(placed.spread) & np.isfinite(xyz).all(axis=1)
    if have.sum() < MIN_SHARED:
        return np.inf
    d = np.linalg.norm(xyz[have] - placed.xyz[have], axis=1)
    return float(np.median(d / placed.spread[have]))


def _px_per_m(cam: Camera, xyz: FloatArray) -> FloatArray:
    """(k,) px per m across the line of sight at world points (k, 3) m in ``cam``:
    focal length over depth."""
    depth = (np.asarray(cam.R, np.float64) @ xyz.T).T[:, 2] + float(np.ravel(cam.t)[2])
    focal = 0.5 * float(np.asarray(cam.K)[0, 0] + np.asarray(cam.K)[1, 1])
    return np.asarray(focal / np.maximum(depth, 1e-6), np.float64)



def prefers_other(ps: Pass, field: BedField, pieces: tuple[Track, ...],
                  shared: tuple[NDArray[np.bool_], ...], fit: PairFit | None, marker: int,
                  markers: list[int]) -> bool:
    """Whether the bed's field speaks against giving ``marker`` to a unit (as
    :func:`spreads_off`): the unit lies beyond ``GATE_SPREADS`` spreads of the marker's
    predicted point, or another of ``markers`` the unit's cameras lack is predicted nearer
    (in spreads). A field that cannot place the marker says nothing."""
    own, _ = spreads_off(ps, field, pieces, shared, fit, marker)
    if not np.isfinite(own):
        return False
    if own > GATE_SPREADS:
        return True
    return any(spreads_off(ps, field, pieces, shared, fit, m)[0] < own
               for m in markers if m != marker)


def nearest_given(ps: Pass, field: BedField, pieces: tuple[Track, ...]) -> float:
    """How near a unit lies to a marker its cameras give out at its stamps, in spreads: the
    least, over such markers, of the median distance between a piece and its camera's
    numbered points of the marker (interpolated to its stamps) over ``FLOOR_M`` at the
    marker's rest depth (a measured point: the floor is its spread); 0 when a piece alone
    lies on the other camera's epipolar lines of a marker that camera gives out and its
    own does not (median within ``MEDIAN_SHARE * epipolar_px``, even if a frame strays);
    inf: none. Such a piece
    may be that marker (its number on a spot beside it, one marker seen twice, a pair
    check failed by one frame), which the field cannot tell from a missing marker it places
    there (on a tuning look at dusk the front's piece of marker 7, on the side's lines of 7
    but for a frame, took buried 12: 10 switches)."""
    best = np.inf
    for p in pieces:
        cam = ps.cameras[p.camera]
        for m, hist in ps.own_2d[p.camera].items():
            at = interpolate_history(hist, p.times, 1.5 / ps.fps)
            have = np.isfinite(at).all(axis=1)
            if not have.any() or m not in field.rest:
                continue
            floor_px = FLOOR_M * float(_px_per_m(cam, field.rest[m][None])[0])
            d = float(np.median(np.linalg.norm(p.uv[have] - at[have], axis=1)))
            best = min(best, d / floor_px)
        if len(pieces) > 1:
            continue
        for m, hist in ps.own_2d[ps.other(p.camera)].items():
            if not lacks(ps.own_2d[p.camera], m, p.times, ps.fps):
                continue  # this camera gives it out elsewhere then: not this piece
            fit = ps.fit(p, interpolate_history(hist, p.times, 1.5 / ps.fps))
            if fit is not None and fit.median_px <= MEDIAN_SHARE * ps.epipolar_px:
                return 0.0
    return best
