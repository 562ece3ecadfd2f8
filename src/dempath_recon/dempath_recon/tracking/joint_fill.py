"""Numbering in 3D over the whole pass: the spots the rules left unnumbered, filled jointly
from each marker's 3D path.

Most found-but-unnumbered spots belong to markers numbered in other frames of the pass (a
track gave its number back where its spot parted, a pair was withheld for a frame or two, the
other camera lost the marker for a while). A marker moves with the sand and cannot jump, so
its 3D path between the frames where both cameras gave it out says where it is in between.
With the whole pass held (``StereoTrackConfig.whole_pass``), after
:func:`~dempath_recon.tracking.whole_pass.number_whole_pass`, :func:`fill_jointly`:

1. **Anchors**: each marker's 3D points from its numbered pairs (each camera's numbered point
   with the other camera's points of that number interpolated to its stamp: the cameras do
   not expose at the same instant), kept only where the pair lies on its epipolar line
   (:func:`marker_paths`).
2. **Prediction**: where a marker is missing in one camera or both, its 3D point at that
   camera's stamp, linear between the anchors either side (at the pass's ends extrapolated
   from the last two, ``END_FRAMES`` at most), with a gate that grows as the bed may
   accelerate: a path with acceleration at most ``ACCEL_M_S2`` strays from the line through
   two of its points at ``t0``, ``t1`` by at most ``a |(t - t0)(t - t1)| / 2``
   (:func:`predict`). Projected into each camera, the gate scaled by focal length over depth.
3. **One assignment per instant** (a frame of each camera, paired by stamp): every marker
   missing there against the unnumbered spots of both cameras jointly. An option is a marker
   with a spot in one camera and a spot in the other (or the point the other camera gives
   out), scored by the spots' distances from the projected prediction, the pair's epipolar
   distance (the other camera's spot moved to this camera's stamp along the path) and its 3D
   point's distance from the path, each over its gate; or a spot in one camera alone when the
   other camera has nothing within the gate (a marker hidden there) and no other spot lies
   within the gate (:func:`instant_options`). One ``scipy.optimize.milp`` over the options (a
   marker and a spot in one option at most; an option is worth the spots it explains less its
   costs) picks the explanation; an option is kept only when the best explanation without it
   is worse by ``MARGIN`` (:func:`clear_options`) and no other marker missing in that camera
   is predicted nearly as near its spot (``RIVAL_RATIO``, ``RIVAL_PX``).
4. Never a number the frame gives out already or withheld there (a rule's event says so:
   :func:`withheld`), never a spot whose own 2D track is another marker within
   ``TRACK_NEAR_FRAMES``: it carries another number there (a track that sat on a neighbour's
   spot: the session-22 back-fill's switches), or its frame gave the marker to another spot
   (the track ran beside it).
5. ``PASSES`` passes, each on the paths with the pairs the pass before filled: a path whose
   marker was numbered late or lost its number early is carried on ``END_FRAMES`` a pass,
   each step checked in both cameras against the path so far.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import project, triangulate_pairs
from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.trajectories import (
    marker_histories,
    paired_points,
)

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
Spot = tuple[int, int]  # (frame index, point index)

BASE_M = 0.003  # a predicted point's error at an anchor [m]: the pair's triangulation noise
# (1-2 mm RMS on the renders) and the cameras' exposure offset, with a margin
ACCEL_M_S2 = 20.0  # the bed's largest acceleration [m/s^2]: sand before the tine reaches the
# tool's speed (1-1.5 m/s) within about 0.1 s
MAX_SPAN_FRAMES = 12  # anchors farther apart than this [frames]: no prediction between them
END_FRAMES = 3  # the path is extrapolated this many frames at most past its ends [frames]
TRACK_NEAR_FRAMES = 5  # a spot whose 2D track is another marker this near in time [frames]
# (it carries another number, or ran beside the marker's given point) is not filled
HIDDEN_COST = 0.3  # what a spot explained by one camera alone costs (the other camera's
# point would have checked it), of a spot's worth of 1
MARGIN = 0.5  # the best explanation without an option must be worse by this (a spot's worth
# is 1): else two explanations fit and the spot stays unnumbered
UNCONFIRMED = 'not yet confirmed by the other camera'  # pair_checks' event of a point that
# waits for the other camera (withheld for lack of evidence, not on evidence against it)
PASSES = 10  # passes, each on the paths with the pairs the pass before filled (a path's ends
# move on by up to END_FRAMES a pass)
RIVAL_RATIO = 2.0  # another marker missing in the camera predicted within this times the
RIVAL_PX = 2.0  # chosen marker's distance plus this [px] of a spot makes it ambiguous


class Path3D(NamedTuple):
    """A marker's anchors: its numbered pairs' 3D points.

    Attributes:
        times: (k,) stamps [s], increasing.
        xyz: (k, 3) world points [m].
    """

    times: FloatArray
    xyz: FloatArray


class Prediction(NamedTuple):
    """A marker's predicted 3D point at one stamp and how far it may be off [m]."""

    xyz: FloatArray
    gate_m: float


class Option(NamedTuple):
    """One explanation: ``marker`` at ``spots`` (frame index, point index), worth ``value``."""

    marker: int
    spots: tuple[Spot, ...]
    value: float


def marker_paths(frames: Sequence[PixelFrame], cameras: dict[str, Camera], epipolar_px: float,
                 fps: float, memo: dict[int, tuple[bytes, Path3D | None]] | None = None,
                 ) -> dict[int, Path3D]:
    """``{marker: Path3D}``: each camera's numbered points with the other camera's points of
    the same number interpolated to their stamps (over gaps of at most 1.5 frame periods),
    triangulated, kept where the pair lies within ``epipolar_px`` of its line; both cameras'
    stamps, in time order. ``memo`` (marker -> (its points' bytes, path)) keeps the paths of
    markers whose points did not change between calls."""
    names = sorted(cameras)
    hist = {c: marker_histories(list(frames), c) for c in names}
    memo = {} if memo is None else memo
    out = {}
    for m in sorted(set(hist[names[0]]) & set(hist[names[1]])):
        key = b''.join(x.tobytes() for c in names for x in hist[c][m])
        if m not in memo or memo[m][0] != key:
            memo[m] = (key, one_path(hist, m, names, cameras, epipolar_px, fps))
        path = memo[m][1]
        if path is not None:
            out[m] = path
    return out


def one_path(hist: dict[str, dict[int, tuple[FloatArray, FloatArray]]], marker: int,
             names: Sequence[str], cameras: dict[str, Camera], epipolar_px: float, fps: float,
             ) -> Path3D | None:
    """:func:`marker_paths` of one marker (None: no pair on its line)."""
    times_all, xyz_all = [], []
    for a, b in (names, names[::-1]):
        times, xyz, epi = paired_points(hist[a][marker], hist[b][marker], cameras[a],
                                        cameras[b], fps)
        if not len(times):
            continue
        good = epi <= epipolar_px
        times_all.append(times[good])
        xyz_all.append(xyz[good])
    if not times_all or not sum(len(t) for t in times_all):
        return None
    t = np.concatenate(times_all)
    order = np.argsort(t, kind='stable')
    return Path3D(t[order], np.concatenate(xyz_all)[order])


def predict(path: Path3D, t: float, fps: float) -> Prediction | None:
    """``path``'s point at ``t`` [s]: linear between the anchors either side (at most
    ``MAX_SPAN_FRAMES`` apart), or past an end from its last two anchors at least half a
    frame apart (``END_FRAMES`` at most); None when neither. The gate is ``BASE_M`` plus
    ``ACCEL_M_S2 |(t - t0)(t - t1)| / 2`` (the two anchors used at ``t0``, ``t1``)."""
    times = path.times
    k = int(np.searchsorted(times, t))
    if 0 < k < len(times):
        i, j = k - 1, k
        if times[j] - times[i] > MAX_SPAN_FRAMES / fps:
            return None
    else:
        if len(times) < 2:
            return None
        end = 0 if k == 0 else len(times) - 1
        if abs(t - times[end]) > END_FRAMES / fps:
            return None
        step = 1 if end == 0 else -1
        far = end + step
        while 0 <= far + step < len(times) and abs(times[far] - times[end]) < 0.5 / fps:
            far += step
        if abs(times[far] - times[end]) < 0.5 / fps:
            return None
        i, j = min(end, far), max(end, far)
    t0, t1 = times[i], times[j]
    w = (t - t0) / (t1 - t0)
    xyz = (1 - w) * path.xyz[i] + w * path.xyz[j]
    return Prediction(xyz, BASE_M + 0.5 * ACCEL_M_S2 * abs((t - t0) * (t - t1)))


def instants(frames: Sequence[PixelFrame], names: Sequence[str], fps: float,
             ) -> list[tuple[int, ...]]:
    """The frames taken together: each of the first camera's frames with the other camera's
    frame nearest in stamp within half a frame period (each used once), then every frame left
    alone; frame indices, the first camera's first."""
    by_cam = {c: [i for i, f in enumerate(frames) if f.camera == c] for c in names}
    stamps = np.array([frames[i].stamp_s for i in by_cam[names[1]]])
    used: set[int] = set()
    out: list[tuple[int, ...]] = []
    for i in by_cam[names[0]]:
        if not len(stamps):
            out.append((i,))
            continue
        d = np.abs(stamps - frames[i].stamp_s)
        j = int(np.argmin(d))
        if d[j] <= 0.5 / fps and j not in used:
            used.add(j)
            out.append((i, by_cam[names[1]][j]))
        else:
            out.append((i,))
    out += [(by_cam[names[1]][j],) for j in range(len(stamps)) if j not in used]
    return out


class TrackNumbers(NamedTuple):
    """One camera's 2D tracks and the numbers around them: track id -> (times (k,) s, its
    number there (k,) (-1: none), the numbers its frame gives to other spots (k,) sets)."""

    by_track: dict[int, tuple[FloatArray, NDArray[np.int64], list[frozenset[int]]]]

    def not_marker(self, track_id: int, t: float, marker: int, within_s: float) -> bool:
        """Whether the track is another marker than ``marker`` within ``within_s`` of ``t``:
        it carries another number there, or its frame gives ``marker`` to another spot (the
        track then was something beside it)."""
        got = self.by_track.get(track_id)
        if got is None:
            return False
        near = np.flatnonzero(np.abs(got[0] - t) <= within_s)
        return any((got[1][i] >= 0 and got[1][i] != marker) or marker in got[2][i]
                   for i in near.tolist())


def track_numbers(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                  camera: str) -> TrackNumbers:
    """``camera``'s tracks with the numbers on and around them."""
    rows: dict[int, list[tuple[float, int, frozenset[int]]]] = {}
    for f, ids in zip(frames, track_ids, strict=True):
        if f.camera != camera:
            continue
        marks = f.markers.tolist()
        given = frozenset(m for m in marks if m >= 0)
        # the numbers around each spot: the frame's others (one set per number given, not
        # per spot: a pass has tens of thousands of spots)
        around = {m: given - {m} for m in given}
        for m, tid in zip(marks, ids.tolist(), strict=True):
            rows.setdefault(int(tid), []).append((f.stamp_s, int(m), around.get(m, given)))
    return TrackNumbers({tid: (np.array([r[0] for r in rs]), np.array([r[1] for r in rs]),
                               [r[2] for r in rs]) for tid, rs in rows.items()})


class View(NamedTuple):
    """A marker in one frame of an instant: the frame, its camera, the predicted point there
    [px] and its gate [px], and the point the frame gives out for it (None: missing)."""

    frame: int
    camera: Camera
    uv: FloatArray
    gate_px: float
    given: FloatArray | None


def view_of(frame: PixelFrame, index: int, camera: Camera, pred: Prediction, marker: int,
            ) -> View:
    """The marker's :class:`View` in ``frame`` (its ``index`` in the pass)."""
    uv = project(camera, pred.xyz[None])[0]
    depth = float((np.asarray(camera.R) @ pred.xyz + np.asarray(camera.t))[2])
    gate = pred.gate_m * float(camera.K[0, 0]) / max(depth, 1e-6)
    hit = np.flatnonzero(frame.markers == marker)
    return View(index, camera, uv, gate, frame.uv[hit[0]] if len(hit) else None)


class Instant(NamedTuple):
    """What the options of one instant read: the frames, their 2D tracks, each camera's
    numbered points by track, the cameras, the paths and the settings."""

    frames: Sequence[PixelFrame]
    track_ids: Sequence[NDArray[np.int64]]
    numbers: dict[str, TrackNumbers]
    cameras: dict[str, Camera]
    paths: dict[int, Path3D]
    epipolar_px: float
    fps: float

    def free(self, view: View, marker: int) -> list[tuple[int, float]]:
        """The unnumbered spots of the view's frame within its gate that may be ``marker``
        (their tracks carry no other number near in time): (point index, distance px)."""
        f = self.frames[view.frame]
        d = np.linalg.norm(f.uv - view.uv, axis=1) if len(f.uv) else np.zeros(0)
        ids = self.track_ids[view.frame]
        return [(k, float(d[k])) for k in np.flatnonzero((f.markers < 0) & (d <= view.gate_px))
                if not self.numbers[f.camera].not_marker(
                    int(ids[k]), f.stamp_s, marker, TRACK_NEAR_FRAMES / self.fps)]

    def crowd(self, view: View) -> int:
        """How many unnumbered spots of the view's frame lie within its gate."""
        f = self.frames[view.frame]
        if not len(f.uv):
            return 0
        return int(((f.markers < 0) & (np.linalg.norm(f.uv - view.uv, axis=1)
                                        <= view.gate_px)).sum())


def pair_cost(inst: Instant, marker: int, a: View, uv_a: FloatArray, b: View, uv_b: FloatArray,
              ) -> float | None:
    """The pair's epipolar and 3D costs (each over its gate, squared; None past a gate): the
    point ``uv_b`` of frame ``b`` moved to ``a``'s stamp along the marker's path (its
    predicted image motion between the stamps), triangulated with ``uv_a``."""
    t_a = inst.frames[a.frame].stamp_s
    at_a = predict(inst.paths[marker], t_a, inst.fps)
    if at_a is None:
        return None
    moved = uv_b + project(b.camera, at_a.xyz[None])[0] - b.uv
    xyz, epi = triangulate_pairs(a.camera, b.camera, uv_a[None], moved[None])
    e = float(epi[0]) / inst.epipolar_px
    d3 = float(np.linalg.norm(xyz[0] - at_a.xyz)) / at_a.gate_m
    if e > 1 or d3 > 1:
        return None
    return e * e + d3 * d3


def instant_options(inst: Instant, frames_here: tuple[int, ...]) -> list[Option]:
    """Every option of one instant (:class:`Option`; worth: 1 per spot explained less each
    spot's squared distance over its gate and the pair's costs; ``HIDDEN_COST`` less for a
    spot the other camera does not check)."""
    out: list[Option] = []
    for m, path in inst.paths.items():
        if all((inst.frames[i].markers == m).any() for i in frames_here):
            continue  # given out in every frame of the instant
        views = []
        for i in frames_here:
            f = inst.frames[i]
            pred = predict(path, f.stamp_s, inst.fps)
            if pred is not None:
                views.append(view_of(f, i, inst.cameras[f.camera], pred, m))
        if not views or all(v.given is not None for v in views):
            continue
        cands = [[] if v.given is not None or withheld(inst.frames[v.frame], m)
                 else inst.free(v, m) for v in views]
        if len(views) == 2:
            out += pair_options(inst, m, views, cands)
        for n, (v, c) in enumerate(zip(views, cands, strict=True)):
            others = [w for w in views if w is not v]
            if len(c) != 1 or inst.crowd(v) != 1 or any(
                    w.given is not None or inst.crowd(w) for w in others):
                continue  # alone in its gate, and nothing of it in the other camera
            k, d = c[0]
            value = 1 - (d / v.gate_px) ** 2 - HIDDEN_COST
            if value > 0:
                out.append(Option(m, ((views[n].frame, k),), value))
    return out


def withheld(frame: PixelFrame, marker: int) -> bool:
    """Whether a rule withheld ``marker`` in ``frame`` on evidence from the frame itself
    against the spot (it may hold a neighbour, its pair is off the line or jumped; its events
    say so), which a path drawn from other frames does not overrule (on the tuning looks
    filling them anyway added a wrong-pair point). A point withheld only while it waits for
    the other camera's confirmation (``UNCONFIRMED``) lacked evidence, which the path and
    the pair give: it may be filled."""
    head = f'{frame.camera}: marker {marker} withheld'
    return any(e.startswith(head) and UNCONFIRMED not in e for e in frame.events)


def pair_options(inst: Instant, marker: int, views: list[View],
                 cands: list[list[tuple[int, float]]]) -> list[Option]:
    """The options of a marker with a view in both cameras: a spot in each, or a spot in the
    one where it is missing with the other camera's given point."""
    a, b = views
    ends_a = [(k, d, inst.frames[a.frame].uv[k]) for k, d in cands[0]] if a.given is None \
        else [(-1, 0.0, a.given)]
    ends_b = [(k, d, inst.frames[b.frame].uv[k]) for k, d in cands[1]] if b.given is None \
        else [(-1, 0.0, b.given)]
    out = []
    for ka, da, uv_a in ends_a:
        for kb, db, uv_b in ends_b:
            cost = pair_cost(inst, marker, a, uv_a, b, uv_b)
            if cost is None:
                continue
            spots = tuple((v.frame, k) for v, k in ((a, ka), (b, kb)) if k >= 0)
            value = len(spots) - (da / a.gate_px) ** 2 - (db / b.gate_px) ** 2 - cost
            if value > 0:
                out.append(Option(marker, spots, value))
    return out


def best_choice(options: Sequence[Option], banned: int | None = None,
                ) -> tuple[float, list[int]]:
    """The most valuable set of ``options`` (but ``banned``) in which no marker and no spot
    appears twice (``scipy.optimize.milp``): its worth and the options' indices."""
    from scipy.optimize import Bounds, LinearConstraint, milp

    keep = [i for i in range(len(options)) if i != banned]
    if not keep:
        return 0.0, []
    groups: dict[object, list[int]] = {}
    for n, i in enumerate(keep):
        groups.setdefault(('marker', options[i].marker), []).append(n)
        for s in options[i].spots:
            groups.setdefault(('spot', s), []).append(n)
    a = np.zeros((len(groups), len(keep)))
    for r, cols in enumerate(groups.values()):
        a[r, cols] = 1
    res = milp(-np.array([options[i].value for i in keep]), integrality=np.ones(len(keep)),
               bounds=Bounds(0, 1), constraints=LinearConstraint(a, 0, 1))
    chosen = [keep[n] for n in np.flatnonzero(np.round(res.x) > 0)] if res.x is not None else []
    return sum(options[i].value for i in chosen), chosen


def clear_options(options: Sequence[Option]) -> list[Option]:
    """The options of the best choice whose removal costs the choice at least ``MARGIN``
    (options that share no marker and no spot: each worth ``MARGIN`` or more, no solver)."""
    keys = [k for o in options for k in (('marker', o.marker), *(('spot', s) for s in o.spots))]
    if len(set(keys)) == len(keys):
        return [o for o in options if o.value >= MARGIN]
    worth, chosen = best_choice(options)
    return [options[i] for i in chosen if worth - best_choice(options, i)[0] >= MARGIN]


def rivalled(inst: Instant, option: Option) -> bool:
    """Whether another marker missing in a spot's frame is predicted within ``RIVAL_RATIO``
    times the option's marker's distance plus ``RIVAL_PX`` of it (the spot may be that one)."""
    for i, k in option.spots:
        f = inst.frames[i]
        cam = inst.cameras[f.camera]
        spot = f.uv[k]
        own = predict(inst.paths[option.marker], f.stamp_s, inst.fps)
        if own is None:
            return True
        d_own = float(np.linalg.norm(project(cam, own.xyz[None])[0] - spot))
        for n, path in inst.paths.items():
            if n == option.marker or (f.markers == n).any():
                continue
            pred = predict(path, f.stamp_s, inst.fps)
            if pred is None:
                continue
            d = float(np.linalg.norm(project(cam, pred.xyz[None])[0] - spot))
            if d < RIVAL_RATIO * d_own + RIVAL_PX:
                return True
    return False


def fill_jointly(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                 cameras: dict[str, Camera], epipolar_px: float, fps: float,
                 ) -> tuple[list[PixelFrame], int]:
    """The pass's frames (both cameras, as they would be given out; ``track_ids`` (k,) each
    point's 2D track) with unnumbered spots numbered from the markers' 3D paths (module
    docstring), and how many points got a number.

    Args:
        frames: every frame of the pass.
        track_ids: per frame, (k,) the track of each point.
        cameras: ``{name: camera}`` of the two cameras.
        epipolar_px: the pipeline's ``epipolar_px``: a pair's line distance gate [px].
        fps: the frame rate [1/s].
    """
    out, given = list(frames), 0
    changed: FloatArray | None = None
    memo: dict[int, tuple[bytes, Path3D | None]] = {}
    for _ in range(PASSES):
        out, filled = fill_pass(out, track_ids, cameras, epipolar_px, fps, changed, memo)
        given += len(filled)
        if not filled:
            break
        changed = np.array(filled)
    return out, given


def fill_pass(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
              cameras: dict[str, Camera], epipolar_px: float, fps: float,
              changed: FloatArray | None, memo: dict[int, tuple[bytes, Path3D | None]],
              ) -> tuple[list[PixelFrame], list[float]]:
    """One pass of :func:`fill_jointly` on the paths of ``frames`` as they are numbered, and
    the stamps of the points it numbered. With ``changed`` (the stamps the pass before
    numbered [s]) only the instants within ``MAX_SPAN_FRAMES + 1`` frames of one of them:
    a pass's decisions at an instant read the anchors no farther, so elsewhere they are the
    pass before's. ``memo``: :func:`marker_paths`' between passes."""
    names = sorted(cameras)
    if not frames:
        return [], []
    inst = Instant(frames, track_ids, {c: track_numbers(frames, track_ids, c) for c in names},
                   cameras, marker_paths(frames, cameras, epipolar_px, fps, memo), epipolar_px,
                   fps)
    markers = [f.markers.copy() for f in frames]
    filled: list[float] = []
    reach = (MAX_SPAN_FRAMES + 1) / fps
    for here in instants(frames, names, fps):
        if changed is not None and not any(
                np.abs(changed - frames[i].stamp_s).min() <= reach for i in here):
            continue
        options = instant_options(inst, here)
        if not options:
            continue
        for opt in clear_options(options):
            if rivalled(inst, opt):
                continue
            for i, k in opt.spots:
                if opt.marker not in markers[i] and markers[i][k] < 0:
                    markers[i][k] = opt.marker
                    filled.append(frames[i].stamp_s)
                    LOG.info('joint fill: %s at %.3f s numbered %d', frames[i].camera,
                             frames[i].stamp_s, opt.marker)
    return [f._replace(markers=m) for f, m in zip(frames, markers, strict=True)], filled
