"""The whole pass audited before anything goes out: no swap published.

The frame-by-frame rules decide a number at one instant; a 2D track that later slides onto a
neighbour, or a late rule that names a track already numbered, leaves a number on another
marker's spot, and the pair checks pass it while the spot stays near the marker's epipolar
line. With the whole pass held (``StereoTrackConfig.whole_pass``), :func:`audit_pass` runs at
``flush`` after every numbering step and decides per **stretch** (the points of one smooth
piece of a 2D track, :func:`~dempath_recon.tracking.whole_pass.smooth_pieces`: no gap, no
jump, that carry one number), never per point:

1. **A piece of track is one marker** (:func:`minority`): a piece that carries two numbers
   keeps the one it carried longest; the other stretch takes it back where no point of its
   frame gives it out, else is taken out.
2. **Each marker's 3D path** (:func:`fit_path`): a curve with one knot per frame period
   (linear between), fitted to every numbered point of the marker in both cameras at the
   point's own stamp (the cameras are not synchronised), by least squares on the linearised
   reprojection error (the DLT rows of each point, weighted by its depth: Hartley & Zisserman,
   *Multiple View Geometry*, 2nd ed., sec. 12.2) plus a penalty on the second differences (a
   discrete smoothing spline: Eilers 2003, "A perfect smoother", Anal. Chem. 75), re-weighted
   with Huber's and then Tukey's weights on each point's pixel residual scaled by the marker's
   size in that image, from a stiff path to a supple one, so that a stretch on another
   marker's spot gets no weight.
3. **A swap** (:func:`find_swap`): a run of a stretch that its own marker does not explain
   (far from the epipolar lines of that marker's points in the other camera, interpolated to
   its stamps as :mod:`~dempath_recon.tracking.trajectories` does: the own marker's path seen
   without the stretch's camera, whose stretch would pull its fit along) while another
   marker's 3D path, projected into the stretch's camera at its stamps, does, ``MARGIN`` times
   nearer: renumbered to that marker when that path lies within ``OTHER_IN`` and no point of
   the camera gives that marker out in those frames, else taken out.

Every change is an event of its frame (``... by the pass audit: ...``) and counted
(``CameraCounts.audit_renumbered``, ``audit_withheld``). A pair whose 3D point strays while
each of its 2D points lies near its marker's path is left alone: every test is in a camera's
image. Measured on session 23's tuning renders (docs/figures.md): switches that form one
smooth 3D path in both cameras (two touching markers exchanged in one camera on one epipolar
line of the other; both cameras re-attached onto a neighbour after a gap) fit their own path
within 0.3 diameters, as right points do: no test on one point's distance from its own path
tells them apart.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.projection import Camera, project_points, undistort_normalized
from dempath_recon.tracking.associate import triangulate_pairs
from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.trajectories import interpolate_history, marker_histories
from dempath_recon.tracking.whole_pass import smooth_pieces

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
UNNUMBERED = -1
SIGMA_PX = 0.5  # a numbered point's centre noise [px] (sub-half-pixel centroids, issue 28)
SIGMA_BEND_M = 0.003  # a path's second difference per frame period [m] (a = 7.5 m/s^2 at 50
# frames/s: sand pushed from rest to the tool's 1 m/s in about 0.1 s; a swap onto a neighbour
# 10-20 mm away bends the path 3-7 times this)
STIFF_SHARE = 0.25  # the first passes' path: this share of SIGMA_BEND_M (nearly straight)
HUBER_SHARE = 0.25  # first re-weighting passes: Huber's k, x the marker's diameter [px]
TUKEY_SHARE = 1.0  # last passes: Tukey's c, x the diameter (a point a diameter off weighs 0)
HUBER_PASSES = 2  # re-weighted least-squares passes with Huber's weights (from a plain fit) ...
TUKEY_PASSES = 3  # ... then with Tukey's (a robust start, then outliers rejected outright)
BAND = 8  # upper diagonals of the normal matrix: 3 coordinates x 2 knots, and 2 more
MIN_POINTS = 2  # weighted points each camera must keep for a path to be fitted (depth)
SUPPORT_FRAMES = 2.5  # a path explains a stamp this near one of its weighted points [frames]
MIN_SHARED = 2  # points of a run compared (fewer: a chance)
FLOOR_SHARE = 0.06  # a point's distance from its line by noise alone [diameters] (0.5 px)
NEAR = 1.5  # another marker's path this near a stretch somewhere makes it a rival [diameters]
OWN_OUT = 0.5  # a run whose median distance from its own marker's lines reaches this
# [diameters] (4 px at 8 px markers: the live pair checks' epipolar_px, within which they take a
# pair as one marker; at 0.15 the front's 7 of test_crowded_pair, 0.22 off the side's 7, went
# to 3, hidden behind it in the front) ...
MARGIN = 3.0  # ... and this many times another marker's path's plus the floor is a swap
OTHER_IN = 0.1  # renumbered only when that marker's path lies within this [diameters]
UNPLACED = 0.5  # a point's distance from its own marker where the other camera does not give
# it out [diameters] (unexplained, though less than a point its lines place elsewhere)


class Path(NamedTuple):
    """One marker's 3D path over the pass.

    Attributes:
        knots: (n,) knot stamps [s], one frame period apart.
        xyz: (n, 3) the path at the knots [m] (linear between them).
        support: (k,) stamps of the points that carry the path (weight > 0) [s].
    """

    knots: FloatArray
    xyz: FloatArray
    support: FloatArray

    def at(self, times: FloatArray, fps: float) -> FloatArray:
        """(len(times), 3) m on the path, NaN where no supporting point lies within
        ``SUPPORT_FRAMES`` frame periods (nothing says where the marker was)."""
        times = np.asarray(times, np.float64)
        out = np.column_stack([np.interp(times, self.knots, self.xyz[:, i]) for i in range(3)])
        if not len(self.support):
            return np.full((len(times), 3), np.nan)
        near = np.abs(times[:, None] - self.support[None, :]).min(axis=1)
        out[near > SUPPORT_FRAMES / fps] = np.nan
        return out


class Points(NamedTuple):
    """One marker's numbered points over the pass, both cameras.

    Attributes:
        cam: (k,) index of each point's camera (into the sorted camera names).
        times: (k,) stamps [s].
        uv: (k, 2) px.
    """

    cam: NDArray[np.int64]
    times: FloatArray
    uv: FloatArray


class AuditResult(NamedTuple):
    """What the audit changed: the frames, and per camera how many points it renumbered
    and how many it withheld."""

    frames: list[PixelFrame]
    renumbered: dict[str, int]
    withheld: dict[str, int]


def knot_weights(knots: FloatArray, times: FloatArray) -> tuple[NDArray[np.int64], FloatArray]:
    """Each stamp's knot to the left (k,) and its share towards the next knot (k,)."""
    step = knots[1] - knots[0] if len(knots) > 1 else 1.0
    pos = np.clip((times - knots[0]) / step, 0, max(len(knots) - 1, 0))
    left = np.minimum(np.floor(pos).astype(np.int64), max(len(knots) - 2, 0))
    return left, pos - left


class DltRows(NamedTuple):
    """Each point's two DLT rows (``(x r3 - r1) . X = t1 - x t3``, likewise y: Hartley &
    Zisserman sec. 12.2) summed into normal-equation terms, before any weight: ``outer`` (k, 3,
    3) the sum of ``a a^T`` and ``moment`` (k, 3) of ``b a`` over the two rows, and ``focal``
    (k,) the camera's focal length [px] (a row times ``focal / depth`` is a pixel error)."""

    outer: FloatArray
    moment: FloatArray
    focal: FloatArray

    @classmethod
    def of(cls, cams: Sequence[Camera], pts: Points) -> DltRows:
        """The rows of every point of ``pts``."""
        k = len(pts.times)
        outer, moment, focal = np.zeros((k, 3, 3)), np.zeros((k, 3)), np.zeros(k)
        for c, cam in enumerate(cams):
            sel = np.flatnonzero(pts.cam == c)
            if not len(sel):
                continue
            xn = undistort_normalized(cam, pts.uv[sel])
            rot, t = np.asarray(cam.R, np.float64), np.asarray(cam.t, np.float64).ravel()
            for axis in (0, 1):
                a = xn[:, axis:axis + 1] * rot[2][None, :] - rot[axis][None, :]
                b = t[axis] - xn[:, axis] * t[2]
                outer[sel] += a[:, :, None] * a[:, None, :]
                moment[sel] += b[:, None] * a
            focal[sel] = float(np.asarray(cam.K)[0, 0])
        return cls(outer, moment, focal)


def bend_penalty(n: int, bend_m: float) -> FloatArray:
    """(n, n): the sum of squared second differences of n knots over ``bend_m`` [m], as a
    quadratic form (``D^T D / bend_m^2``, D the (n - 2, n) second-difference matrix)."""
    out = np.zeros((n, n))
    for k in range(n - 2):
        out[k:k + 3, k:k + 3] += np.array([[1.0, -2.0, 1.0], [-2.0, 4.0, -2.0], [1.0, -2.0, 1.0]])
    return out / bend_m ** 2


def solve_path(rows: DltRows, left: NDArray[np.int64], share: FloatArray, gain: FloatArray,
               penalty: FloatArray) -> FloatArray:
    """(n, 3) m: the knots' points minimising the points' DLT rows, each point's squared
    rows times ``gain`` (k,) (its weight times ``(focal / depth / SIGMA_PX)^2``: pixel errors
    over their noise) and shared between its knots ``left`` (k,) and the next by ``share``
    (k,), plus the quadratic form ``penalty`` (n, n) on each coordinate.

    The normal equations are summed point by point (each touches two knots) and solved as a
    banded system (``scipy.linalg.solveh_banded``): a BLAS product of the stacked rows runs
    threaded and, on a loaded 2-core machine, 100 times slower than the sums."""
    from scipy.linalg import solveh_banded

    n = len(penalty)
    ends = ((left, 1 - share), (np.minimum(left + 1, n - 1), share))
    outer = gain[:, None, None] * rows.outer
    moment = gain[:, None] * rows.moment
    normal = np.zeros((n, 3, n, 3))
    np.add.at(normal, (np.concatenate([p for p, _ in ends for _ in ends]), slice(None),
                       np.concatenate([q for _ in ends for q, _ in ends])),  # type: ignore[arg-type]
              np.concatenate([(wp * wq)[:, None, None] * outer
                              for _, wp in ends for _, wq in ends]))
    rhs = np.zeros((n, 3))
    np.add.at(rhs, np.concatenate([p for p, _ in ends]),
              np.concatenate([wp[:, None] * moment for _, wp in ends]))
    normal += penalty[:, None, :, None] * np.eye(3)[None, :, None, :]
    flat = normal.reshape(3 * n, 3 * n)
    band = min(BAND, 3 * n - 1)  # a knot meets the knots two away (the bend): 8 diagonals
    packed = np.zeros((band + 1, 3 * n))
    for d in range(band + 1):
        packed[band - d, d:] = np.diagonal(flat, d)
    try:
        sol = solveh_banded(packed, rhs.reshape(3 * n))
    except np.linalg.LinAlgError:  # not positive definite: a camera's rows all dropped
        sol = np.linalg.lstsq(flat, rhs.reshape(3 * n), rcond=None)[0]
    return np.asarray(sol.reshape(n, 3), np.float64)


def residuals_px(cams: Sequence[Camera], pts: Points, knots: FloatArray, xyz: FloatArray,
                 ) -> tuple[FloatArray, FloatArray]:
    """Each point's distance to the path projected into its camera at its stamp (k,) px, and
    its depth there (k,) m."""
    at = np.column_stack([np.interp(pts.times, knots, xyz[:, i]) for i in range(3)])
    res, depth = np.full(len(pts.times), np.inf), np.ones(len(pts.times))
    for c, cam in enumerate(cams):
        sel = pts.cam == c
        if not sel.any():
            continue
        res[sel] = np.linalg.norm(project_points(cam, at[sel]) - pts.uv[sel], axis=1)
        z = (at[sel] * np.asarray(cam.R, np.float64)[2]).sum(axis=1) \
            + float(np.asarray(cam.t, np.float64).ravel()[2])
        depth[sel] = np.where(z > 1e-3, z, 1.0)
    res[~np.isfinite(res)] = np.inf
    return res, depth


def fit_path(cams: Sequence[Camera], pts: Points, diameter_px: FloatArray, fps: float,
             ) -> tuple[Path, FloatArray] | None:
    """A marker's robust path through its points (``Points``; ``diameter_px`` (n_cams,) the
    marker's size in each image), and each point's final weight (k,); None when either camera
    keeps fewer than ``MIN_POINTS`` points (the depth is not known).

    Iteratively re-weighted least squares (:func:`solve_path`): a plain fit and Huber's
    weights on a stiff path first (``STIFF_SHARE`` of ``SIGMA_BEND_M``: a stretch on a
    neighbour's spot, up the other camera's line of sight where nothing else holds the path,
    would bend a supple one towards it and look half right), then Tukey's on the supple one."""
    t0, t1 = float(pts.times.min()), float(pts.times.max())
    knots = t0 + np.arange(int(np.ceil((t1 - t0) * fps - 1e-6)) + 1) / fps
    weight: FloatArray = np.ones(len(pts.times))
    depth: FloatArray = np.ones(len(pts.times))
    scale = diameter_px[pts.cam]
    xyz: FloatArray = np.zeros((len(knots), 3))
    rows = DltRows.of(cams, pts)
    left, share = knot_weights(knots, pts.times)
    stiff, supple = (bend_penalty(len(knots), SIGMA_BEND_M * f) for f in (STIFF_SHARE, 1.0))
    for it in range(1 + HUBER_PASSES + TUKEY_PASSES):
        if any((weight[pts.cam == c] > 0).sum() < MIN_POINTS for c in range(len(cams))):
            return None
        gain = weight * (rows.focal / depth / SIGMA_PX) ** 2
        xyz = solve_path(rows, left, share, gain, stiff if it <= HUBER_PASSES else supple)
        res, depth = residuals_px(cams, pts, knots, xyz)
        if it < HUBER_PASSES:
            weight = np.minimum(1.0, HUBER_SHARE * scale / np.maximum(res, 1e-9))
        else:
            u = res / (TUKEY_SHARE * scale)
            weight = np.asarray(np.where(u < 1, 1 - u ** 2, 0.0), np.float64)
    if any((weight[pts.cam == c] > 0).sum() < MIN_POINTS for c in range(len(cams))):
        return None
    return Path(knots, xyz, pts.times[weight > 0]), weight


def marker_points(frames: Sequence[PixelFrame], names: list[str]) -> dict[int, Points]:
    """``{marker: Points}`` of every numbered point of the pass."""
    rows: dict[int, list[tuple[int, float, float, float]]] = {}
    for f in frames:
        c = names.index(f.camera)
        for m, p in zip(f.markers.tolist(), f.uv.tolist(), strict=True):
            if m >= 0:
                rows.setdefault(m, []).append((c, f.stamp_s, p[0], p[1]))
    out = {}
    for m, rs in rows.items():
        arr = np.array(rs, np.float64)
        out[m] = Points(arr[:, 0].astype(np.int64), arr[:, 1], arr[:, 2:4])
    return out


class Stretch(NamedTuple):
    """The points of one smooth piece of a 2D track (no gap, no jump:
    :func:`~dempath_recon.tracking.whole_pass.smooth_pieces`) that carry one number.

    Attributes:
        camera: its camera.
        piece: (camera, track id, piece index): the piece it belongs to.
        marker: the number.
        where: (frame index, place in the frame) of each point, in time order.
        times: (k,) their stamps [s].
        uv: (k, 2) their pixels [px].
    """

    camera: str
    piece: tuple[str, int, int]
    marker: int
    where: list[tuple[int, int]]
    times: FloatArray
    uv: FloatArray


def stretches(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
              fps: float) -> list[Stretch]:
    """Every numbered point of the pass in its stretch: each camera's tracks cut into smooth
    pieces, each piece's points grouped by their number."""
    tracks: dict[tuple[str, int], list[tuple[int, int]]] = {}
    for i, (f, ids) in enumerate(zip(frames, track_ids, strict=True)):
        for k, tid in enumerate(ids.tolist()):
            tracks.setdefault((f.camera, int(tid)), []).append((i, k))
    out = []
    for (cam, tid), where in tracks.items():
        times = np.array([frames[i].stamp_s for i, _ in where])
        uv = np.array([frames[i].uv[k] for i, k in where]).reshape(-1, 2)
        for n, piece in enumerate(smooth_pieces(times, uv, fps)):
            numbers = [int(frames[where[j][0]].markers[where[j][1]]) for j in piece.tolist()]
            for m in sorted(set(numbers) - {UNNUMBERED}):
                sel = piece[np.array(numbers) == m]
                out.append(Stretch(cam, (cam, tid, n), m, [where[j] for j in sel.tolist()],
                                   times[sel], uv[sel]))
    return out


def minority(group: list[Stretch]) -> list[Stretch]:
    """Of the stretches of one piece, those whose number is not the piece's: a piece of a 2D
    track is one marker, so it carries one number; the one it carries longest (the earliest
    on a tie: most often given by the grid fit) is taken as its own."""
    if len(group) < 2:
        return []
    keep = max(group, key=lambda s: (len(s.where), -s.times[0]))
    return [s for s in group if s is not keep]


def ray_distances(s: Stretch, cam: Camera, other_cam: Camera,
                  hist: tuple[FloatArray, FloatArray] | None, diameter: float,
                  fps: float) -> FloatArray:
    """(k,) diameters: each point of the stretch from the epipolar line of a marker's point in
    the other camera (``hist``: its numbered points, interpolated to the stamps as
    :mod:`~dempath_recon.tracking.trajectories` does; NaN where it has none within 1.5 frame
    periods): the marker's path seen by that camera alone (a ray per instant)."""
    d = np.full(len(s.times), np.nan)
    if hist is None:
        return d
    ouv = interpolate_history(hist, s.times, 1.5 / fps)
    ok = np.isfinite(ouv).all(axis=1)
    if ok.any():
        _, epi = triangulate_pairs(other_cam, cam, ouv[ok], s.uv[ok])
        d[ok] = epi / diameter
    return d


def worst_run(score: FloatArray) -> tuple[int, int]:
    """The contiguous run ``[a, b)`` of largest sum of ``score`` (k,) (NaN ends a run: nothing
    to compare there); (0, 0) when no score is positive (Kadane's algorithm)."""
    best, best_ab, run, start = 0.0, (0, 0), 0.0, 0
    for k, x in enumerate(score.tolist()):
        if not np.isfinite(x):
            run, start = 0.0, k + 1
            continue
        if run <= 0:
            run, start = 0.0, k
        run += x
        if run > best:
            best, best_ab = run, (start, k + 1)
    return best_ab


class Swap(NamedTuple):
    """A run of a stretch that another marker's path explains: its points ``[a, b)``, that
    marker, and both medians [diameters]."""

    a: int
    b: int
    other: int
    own: float
    theirs: float


def find_swap(own: FloatArray, theirs: dict[int, FloatArray]) -> Swap | None:
    """The run of a stretch its own marker's path does not explain (``own`` (k,) diameters;
    NaN: nothing places the marker there, taken as ``UNPLACED``) while another marker's does
    (``theirs``: marker -> (k,) diameters), the clearest over the other markers; None: none."""
    own = np.where(np.isnan(own), UNPLACED, own)
    found: Swap | None = None
    best = 0.0
    for n, d in theirs.items():
        score = own - MARGIN * d - FLOOR_SHARE
        a, b = worst_run(score)
        if b - a < MIN_SHARED:
            continue
        med_own, med_theirs = float(np.median(own[a:b])), float(np.median(d[a:b]))
        total = float(np.sum(score[a:b]))
        if med_own >= OWN_OUT and med_own >= MARGIN * med_theirs + FLOOR_SHARE and total > best:
            best, found = total, Swap(a, b, n, med_own, med_theirs)
    return found


class Evidence(NamedTuple):
    """What the audit reads of the pass.

    Attributes:
        names: the cameras' names, sorted.
        cams: the cameras, in that order.
        size: (2,) a marker's diameter in each camera's image [px].
        paths: marker -> its 3D path (:func:`fit_path`; markers both cameras numbered).
        stamps: camera -> (T,) its frames' stamps [s], increasing.
        seen: camera -> marker -> (T, 2) px: the marker's path projected into the camera at
            each of its stamps (NaN where the path says nothing).
        hist: camera -> marker -> its numbered points (``marker_histories``).
        fps: the frame rate [1/s].
    """

    names: list[str]
    cams: list[Camera]
    size: FloatArray
    paths: dict[int, Path]
    stamps: dict[str, FloatArray]
    seen: dict[str, dict[int, FloatArray]]
    hist: dict[str, dict[int, tuple[FloatArray, FloatArray]]]
    fps: float

    @classmethod
    def of(cls, frames: Sequence[PixelFrame], cameras: dict[str, Camera],
           diameter_px: dict[str, float], fps: float) -> Evidence:
        """The evidence of ``frames``."""
        names = sorted(cameras)
        cams = [cameras[c] for c in names]
        size = np.array([diameter_px[c] for c in names])
        paths = {}
        for m, pts in marker_points(frames, names).items():
            fitted = fit_path(cams, pts, size, fps)
            if fitted is not None:
                paths[m] = fitted[0]
        stamps = {c: np.array(sorted({f.stamp_s for f in frames if f.camera == c}))
                  for c in names}
        seen: dict[str, dict[int, FloatArray]] = {c: {} for c in names}
        for c, cam in zip(names, cams, strict=True):
            for m, path in paths.items():
                at = path.at(stamps[c], fps)
                uv = np.full((len(at), 2), np.nan)
                ok = np.isfinite(at).all(axis=1)
                if ok.any():
                    uv[ok] = project_points(cam, at[ok])
                seen[c][m] = uv
        return cls(names, cams, size, paths, stamps, seen,
                   {c: marker_histories(list(frames), c) for c in names}, fps)

    def distances(self, s: Stretch, marker: int) -> FloatArray:
        """(k,) diameters of the stretch from ``marker``'s 3D path in its camera (a marker
        only one camera numbered: from that camera's points' epipolar lines)."""
        c = self.names.index(s.camera)
        seen = self.seen[s.camera].get(marker)
        if seen is not None:
            at = seen[np.searchsorted(self.stamps[s.camera], s.times)]
            return np.asarray(np.linalg.norm(at - s.uv, axis=1) / self.size[c], np.float64)
        return self.line_distances(s, marker)

    def line_distances(self, s: Stretch, marker: int) -> FloatArray:
        """(k,) diameters of the stretch from the epipolar lines of ``marker``'s points in the
        other camera (:func:`ray_distances`): its own marker's path as that camera sees it,
        the stretch's camera left out (a stretch on a neighbour's spot pulls its marker's
        fitted path along)."""
        c = self.names.index(s.camera)
        o = 1 - c
        return ray_distances(s, self.cams[c], self.cams[o],
                             self.hist[self.names[o]].get(marker), float(self.size[c]),
                             self.fps)

    def rivals(self, s: Stretch) -> dict[int, FloatArray]:
        """``{marker: (k,) diameters}`` of the stretch from every other marker's path
        (:meth:`distances`) that comes within ``NEAR`` of it somewhere."""
        out = {}
        for m in sorted(set(self.paths) | set(self.hist[self.names[0]])
                        | set(self.hist[self.names[1]])):
            if m == s.marker:
                continue
            d = self.distances(s, m)
            if np.isfinite(d).sum() >= MIN_SHARED and np.nanmin(d) <= NEAR:
                out[m] = d
        return out


def audit_pass(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
               cameras: dict[str, Camera], diameter_px: dict[str, float], fps: float,
               renumber: bool = True) -> AuditResult:
    """The pass's frames (both cameras, as they would be given out; ``track_ids`` (k,) each
    point's track) with the points of a piece of track that carry another number than the
    piece's taken out, then every swap taken out or renumbered (the module's steps).

    Args:
        frames: every frame of the pass.
        track_ids: per frame, (k,) the track of each point.
        cameras: ``{name: camera}`` of the two cameras.
        diameter_px: ``{camera: a marker's diameter in its image [px]}``.
        fps: the frame rate [1/s].
        renumber: give a stretch the number the audit finds for it (the piece's longer one,
            the other marker's whose path explains a swap); False: only withhold it (the
            pipeline's default, ``StereoTrackConfig.audit_renumber``: where the stretch's
            camera does not give that marker out, the marker's path there is placed by the
            other camera alone, its depth along that camera's ray only extrapolated, and a
            number given on it makes a pair of two markers' spots).
    """
    names = sorted(cameras)
    result = AuditResult(list(frames), dict.fromkeys(names, 0), dict.fromkeys(names, 0))
    if not all(diameter_px[c] > 0 for c in names):  # no size known: nothing to scale by
        return result
    pieces: dict[tuple[str, int, int], list[Stretch]] = {}
    for s in stretches(frames, track_ids, fps):
        pieces.setdefault(s.piece, []).append(s)
    for group in pieces.values():
        out = minority(group)
        keep = next((g.marker for g in group if g not in out), UNNUMBERED)
        for s in out:
            free = renumber and all(keep not in result.frames[i].markers for i, _ in s.where)
            take_out(result, s, range(len(s.where)), keep if free else UNNUMBERED,
                     f'its piece of track carries {keep} longer')
    ev = Evidence.of(result.frames, cameras, diameter_px, fps)
    for s in stretches(result.frames, track_ids, fps):
        theirs = ev.rivals(s)
        if not theirs:
            continue
        swap = find_swap(ev.line_distances(s, s.marker), theirs)
        if swap is None:
            continue
        run = range(swap.a, swap.b)
        free = renumber and swap.theirs <= OTHER_IN and all(
            swap.other not in result.frames[s.where[j][0]].markers for j in run)
        take_out(result, s, run, swap.other if free else UNNUMBERED,
                 f'{swap.own:.2f} diameters off its path, {swap.theirs:.2f} off '
                 f"{swap.other}'s")
    return result


def take_out(result: AuditResult, s: Stretch, run: range, other: int, why: str) -> None:
    """Points ``run`` of stretch ``s`` renumbered ``other`` (-1: unnumbered), in place, with an
    event each and counted."""
    frames = result.frames
    for j in run:
        i, k = s.where[j]
        f = frames[i]
        markers = f.markers.copy()
        markers[k] = other
        verb = f'renumbered {other}' if other >= 0 else 'withheld'
        event = (f'{s.camera}: marker {s.marker} {verb} at {f.stamp_s:.3f} s by the pass '
                 f'audit: {why}')
        frames[i] = f._replace(markers=markers, events=(*f.events, event))
    (result.renumbered if other >= 0 else result.withheld)[s.camera] += len(run)
    LOG.info('pass audit: %s marker %d, %d points %s: %s', s.camera, s.marker, len(run),
             f'renumbered {other}' if other >= 0 else 'withheld', why)
