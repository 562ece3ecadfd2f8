"""A spot that two numbered tracks predict is split where the tracks say two markers are.

Markers bunched in front of a tine run into one another in one camera's image and their blob
shows one spot, its centre between them. The detector's own split
(:mod:`~dempath_recon.tracking.split`) reads only the blob's shape: a blob no larger than one
and a half markers, with one peak, stays one spot. The tracker then links it to one of the
two tracks (or withholds it as ambiguous) and the other track is lost; many later switches and
never-numbered tracks start there (a released tuning set, heldout21: 3.3 % of the visible
marker-frames lost in merges, ``merged`` and ``crowded`` in the miss census).

The tracks know more than the blob: where each of their markers should be now (its constant
velocity prediction) and, from the other camera, on which epipolar line each lies. Here, before
linking, two kinds of spot are refitted:

- a spot that holds the predictions of two or three numbered tracks of this camera (running,
  or lost within ``MERGE_S``; each prediction nearer this spot than any other and within
  ``REACH`` marker diameters of it), each started at its track's prediction;
- a spot wider than one marker (radius of gyration over ``WIDE`` diameters) crossed within
  ``LINE_REACH`` diameters by the epipolar line of a number the other camera gives out now
  and this camera holds on no track (a marker that ran into a neighbour's spot before its
  track here was numbered, or whose track was lost): that number is started on its line,
  where the spot's centre (the mean of its markers) puts it beside the tracked ones. It gets
  no number here: its part starts (or re-attaches) a track the numbering names by its own
  evidence.

The fit is the detector's split's image model (:mod:`~dempath_recon.tracking.cut_discs`: a
union of discs of the marker's image size in this frame, each cut by the sand in front of it),
fitted to the blob's chroma in its own box (as the detector's split fits it) once with one
disc and once with one disc per number, started as above. The spot becomes that many markers
only when all of these hold:

- the several discs fit clearly better: their squared residual is ``GAIN`` times lower;
- their centres are at least ``MIN_SEPARATION`` radii apart, and each lies within ``DRIFT``
  diameters of the place it started from (the fit did not swap or merge them);
- a part only the lines placed lies farther than ``REACH`` diameters from the frame's other
  spots (else it is a marker the detector found beside the spot), and each such number is
  placed in one spot at most;
- each centre lies on its number's epipolar line in the other camera (within ``epipolar_px``
  of the line of the other camera's numbered point, given out within a frame period), and no
  more than ``LINE_SLACK`` of that nearer another of the spot's numbers' lines (the pair
  checks would call it wrong anyway). A number the other camera withholds now cannot be
  checked, and its spot is not split.

Otherwise the spot stays as detected and the rules after linking withhold it as before. A
split spot's markers are given as the middle of each one's seen part (what the tracks follow)
and their disc centres (published), and each track is barred from the other parts, so the
link gives every track its own disc. Nothing here numbers a track: the numbers stay those the
tracks had, and the pair checks still check every pair.

Measured (session 22, track37; docs/figures.md): the released tuning set heldout21 79.29 ->
81.46 % numbered right, switches 45 -> 44, wrong pairs 6 -> 6, the split markers' centres
0.2-2.4 px (median per look) from the truth; but on the 23 tiny tuning looks switches 25 -> 35
and wrong pairs 1 -> 7 (the numbering after right splits), so it is off by default
(``StereoTrackConfig.track_split``). Tried and not kept: the other camera's running track of a
number it withheld as the line (a dusk look: that track sat on a neighbour's spot in both
cameras, 7 switches added), a gain of 1.25 (the same), each disc's own uncovered share as the
detector's split asks it (fewer good splits), the fit over a square of three diameters rather
than the blob's box (sand noise filled the residual: true pairs fitted only 1.1-1.5 times
better than one disc).
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import back_project, depth, epipolar_distance, project
from dempath_recon.tracking.cut_discs import fit_cut_discs
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.split import MARGIN, seen_centroid
from dempath_recon.tracking.state import StereoState, at_stamp

FloatArray = NDArray[np.float64]
MERGE_S = 0.1  # a numbered track lost at most this long ago [s] still predicts its marker
REACH = 0.75  # a prediction within this many marker diameters of a spot is in it
MAX_TRACKS = 3  # most markers one spot is split into
GAIN = 1.5  # the several discs must lower the squared residual this many times
MIN_SEPARATION = 0.9  # fitted centres closer than this many radii are one marker
DRIFT = 0.5  # a fitted centre farther than this many diameters from its start is not believed
LINE_REACH = 0.6  # a number the other camera places is in a spot whose centre lies within this
# many marker diameters of its epipolar line
WIDE = 0.33  # a spot is tried on the lines alone only when its radius of gyration exceeds this
# share of a marker's diameter (a lone marker's: median 0.29, 99 % below 0.35; detect.py)
HALF_WIDTH = 1.5  # the refitted square reaches this many diameters around the spot
LINE_SHARE = 1.0  # each centre within this share of epipolar_px of its number's line
LINE_SLACK = 0.25  # a point may lie this share of epipolar_px nearer another number's line
BASE_SHARE = 0.5  # chroma above this share of the detector's threshold belongs to a marker


def predicted_in_spots(state: StereoState, camera: str, uv: FloatArray, stamp_s: float,
                       diameter_px: float) -> dict[int, list[tuple[int, FloatArray]]]:
    """Spot index -> [(track id, predicted place (2,) px)] of the numbered tracks (running, or
    lost within ``MERGE_S``) whose prediction lies within ``REACH`` diameters of that spot of
    ``uv`` (n, 2) px and nearer it than any other, for spots holding 2..``MAX_TRACKS`` of
    them."""
    tracker = state.trackers[camera]
    if not len(uv):
        return {}
    spots: dict[int, list[tuple[int, FloatArray]]] = {}
    for track in tracker.tracks:
        if track.marker < 0 or (track.lost and stamp_s - track.last_stamp_s > MERGE_S + 1e-9):
            continue
        p = track.predict(stamp_s, tracker.config.velocity_decay)
        d = np.linalg.norm(uv - p, axis=1)
        i = int(np.argmin(d))
        if d[i] <= REACH * diameter_px:
            spots.setdefault(i, []).append((track.track_id, p))
    return {i: v for i, v in spots.items() if len(v) <= MAX_TRACKS}


def running_numbers(state: StereoState, camera: str, uv: FloatArray, stamp_s: float,
                    diameter_px: float) -> dict[int, int]:
    """Marker -> the spot of ``uv`` (n, 2) px nearest the prediction of this camera's running
    numbered track of it (-1: none within ``REACH`` diameters): numbers this camera holds."""
    tracker = state.trackers[camera]
    out: dict[int, int] = {}
    for track in tracker.tracks:
        if track.marker < 0 or track.lost:
            continue
        d = np.linalg.norm(uv - track.predict(stamp_s, tracker.config.velocity_decay), axis=1)
        i = int(np.argmin(d))
        out[track.marker] = i if d[i] <= REACH * diameter_px else -1
    return out


def other_place(state: StereoState, other: str, marker: int, stamp_s: float, period: float,
                ) -> FloatArray | None:
    """(2,) px where the ``other`` camera gave ``marker`` out within ``period`` [s] of
    ``stamp_s`` (its latest numbered sighting, checked by the pair checks), moved to
    ``stamp_s`` along its track; None: not given out then. (Its running track of that number
    when the point was withheld was tried too: on a dusk look the track sat on a neighbour's
    spot in both cameras and the split it allowed added 7 switches.)"""
    hit = state.latest[other].get(marker)
    if hit is None or abs(hit[0] - stamp_s) > period:
        return None
    return at_stamp(state, other, marker, hit, stamp_s)


def line_through(cam_other: Camera, cam_here: Camera, other_uv: FloatArray, at_depth: float,
                 ) -> tuple[FloatArray, FloatArray]:
    """``(point (2,), direction (2,))`` px of the epipolar line in ``cam_here`` of the other
    camera's point ``other_uv`` (2,) px, about the depth ``at_depth`` [m] (straight there: the
    lens bends it by a fraction of a pixel over a marker)."""
    ends = np.array([back_project(cam_other, other_uv, f * at_depth) for f in (0.95, 1.05)])
    a, b = project(cam_here, ends)
    step = b - a
    return np.asarray(a, np.float64), np.asarray(step / max(float(np.hypot(*step)), 1e-9),
                                                 np.float64)


def on_line(point: FloatArray, line: tuple[FloatArray, FloatArray]) -> FloatArray:
    """(2,) px the foot of ``point`` (2,) px on ``line`` (point, unit direction)."""
    a, u = line
    return np.asarray(a + np.dot(point - a, u) * u, np.float64)


def line_numbers(state: StereoState, camera: str, det: Detections, spot: int, stamp_s: float,
                 diameter_px: float, held: set[int], starts: list[FloatArray],
                 ) -> list[tuple[int, FloatArray]]:
    """``[(marker, start (2,) px)]``: the numbers the other camera places now whose epipolar
    line crosses spot ``spot`` of ``det`` within ``LINE_REACH`` diameters, and that this
    camera holds (``held``: the numbers of its running tracks and of the tracks predicting a
    spot; those predicting this spot are the tracked ones, ``starts`` their places). Each starts
    on its line where the spot's centre puts it beside the tracked ones: a blob of ``k``
    markers has its centre at their mean."""
    other = state.other(camera)
    cam_o, cam_h = state.cameras[other], state.cameras[camera]
    period = 1.0 / state.config.fps
    centre = det.uv[spot]
    recent = [(m, at_stamp(state, other, m, hit, stamp_s))
              for m, hit in sorted(state.latest[other].items())
              if m not in held and abs(hit[0] - stamp_s) <= period]
    if not recent:
        return []
    near = epipolar_distance(cam_o, cam_h, np.array([p for _, p in recent]), centre[None])[:, 0]
    candidates = [r for r, d in zip(recent, near, strict=True) if d <= LINE_REACH * diameter_px]
    if not candidates or len(candidates) + len(starts) < 2 \
            or len(candidates) + len(starts) > MAX_TRACKS:
        return []
    _, xyz = state.config.grid.points()
    at_depth = float(np.median([depth(cam_o, p) for p in xyz]))
    k = len(candidates) + len(starts)
    rest = (k * centre - np.sum(starts, axis=0)) / len(candidates) if starts else centre
    return [(m, on_line(rest, line_through(cam_o, cam_h, placed, at_depth)))
            for m, placed in candidates]


def apart(points: FloatArray, others: FloatArray, diameter_px: float) -> bool:
    """Whether every one of ``points`` (k, 2) px lies farther than ``REACH`` diameters from
    every one of the frame's other spots ``others`` (n, 2) px."""
    if not len(points) or not len(others):
        return True
    gaps = np.linalg.norm(points[:, None] - others[None], axis=2)
    return bool(gaps.min() > REACH * diameter_px)


def lines_agree(cam_other: Camera, cam_here: Camera, other_uv: FloatArray, uv: FloatArray,
                tolerance_px: float) -> bool:
    """Whether each point ``uv`` (k, 2) px lies within ``tolerance_px`` of the epipolar line
    of its own partner ``other_uv`` (k, 2) px of the other camera, and no farther from it
    than from another partner's line by more than ``LINE_SLACK`` of the tolerance (lines
    that close cannot tell the points apart; farther apart, a point nearer another number's
    line is that marker's)."""
    epi = epipolar_distance(cam_other, cam_here, other_uv, uv)  # (partners, points)
    own = np.diag(epi)
    if not (own <= tolerance_px).all():
        return False
    rival = np.where(np.eye(len(uv), dtype=bool), np.inf, epi).min(axis=0)
    return bool((own <= rival + LINE_SLACK * tolerance_px).all())


def refit_spot(det: Detections, spot: int, starts: FloatArray, diameter_px: float,
               scale: int, threshold: float, up: FloatArray | None,
               ) -> tuple[FloatArray, FloatArray] | None:
    """``(seen (k, 2), discs (k, 2))`` [full-size px] of the ``k = len(starts)`` markers of
    ``det``'s spot ``spot`` fitted from ``starts`` (k, 2) [full-size px], or None when the
    spot's chroma does not say ``k`` markers (``GAIN``, ``MIN_SEPARATION``, ``DRIFT``).

    ``scale``: the detector's downscale; ``threshold``: its chroma threshold; ``up``: the
    image direction of world up the detector cuts discs along (None: whole discs)."""
    if det.patch is None:
        return None
    centre = det.uv[spot]
    patch, origin = det.patch(centre, HALF_WIDTH * diameter_px)
    if patch.size == 0:
        return None
    base = BASE_SHARE * threshold
    blob = _blob_of(patch, origin, (centre + 0.5) / scale - 0.5, base)
    if blob is None:
        return None
    own, origin = blob
    radius = 0.5 * diameter_px / scale
    start = (np.asarray(starts, np.float64) + 0.5) / scale - 0.5
    one = fit_cut_discs(own, origin, ((centre + 0.5) / scale - 0.5)[None], radius, up)
    many = fit_cut_discs(own, origin, start, radius, up)
    c = many.centres
    gaps = np.linalg.norm(c[:, None] - c[None], axis=2)[np.triu_indices(len(c), 1)]
    drift = np.linalg.norm(c - start, axis=1)
    if not (many.cost * GAIN < one.cost and gaps.min() >= MIN_SEPARATION * many.radius
            and (drift <= DRIFT * 2 * radius).all()):
        return None
    seen = seen_centroid(many, up)
    return (seen + 0.5) * scale - 0.5, (c + 0.5) * scale - 0.5


def _blob_of(patch: NDArray[np.float32], origin: tuple[int, int], at: FloatArray,
             base: float) -> tuple[NDArray[np.float32], tuple[int, int]] | None:
    """The blob (chroma above ``base``, 8-connected) of ``patch`` (corner ``origin``
    [detector px]) that holds the point ``at`` (2,) [detector px], in its bounding box grown
    by ``split.MARGIN`` pixels, every pixel outside it held to ``base`` at most (a
    neighbour's blob is not fitted), and that box's corner; None when the point is on no blob.
    Fitted in that box, as the detector's split fits a blob, the residual is the blob's."""
    mask = (patch > base).view(np.uint8)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    col, row = int(np.rint(at[0])) - origin[0], int(np.rint(at[1])) - origin[1]
    if not (0 <= row < patch.shape[0] and 0 <= col < patch.shape[1]):
        return None
    lab = int(labels[row, col])
    if lab == 0:
        return None
    x, y, w, h = (int(v) for v in stats[lab, :4])
    x0, y0 = max(x - MARGIN, 0), max(y - MARGIN, 0)
    x1, y1 = min(x + w + MARGIN, patch.shape[1]), min(y + h + MARGIN, patch.shape[0])
    box = patch[y0:y1, x0:x1]
    inside = labels[y0:y1, x0:x1] == lab
    return (np.where(inside, box, np.minimum(box, np.float32(base))).astype(np.float32),
            (origin[0] + x0, origin[1] + y0))


def split_by_tracks(state: StereoState, camera: str, det: Detections, stamp_s: float,
                    diameter_px: float, scale: int, threshold: float, up: FloatArray | None,
                    shift_px: FloatArray | None, events: list[str],
                    ) -> tuple[Detections, dict[int, NDArray[np.bool_]]]:
    """``det`` with every spot its tracks say holds two or three markers replaced by their
    fitted markers, and the links each of those tracks is barred from (the other parts).

    Args:
        state: the tracker's state (its tracks and the other camera's sightings; unchanged).
        camera: this frame's camera.
        det: the frame's detections (in the calibration's view: moved back by ``shift_px``).
        stamp_s: the frame's stamp [s].
        diameter_px: a marker's image diameter [full-size px] (0: nothing is split).
        scale: the detector's downscale.
        threshold: the detector's chroma threshold.
        up: the detector's up direction for cut discs (None: whole discs).
        shift_px: (2,) the frame's shake taken off ``det`` [px] (None: none).
        events: where a split is said.

    Returns:
        ``(det, barred)``: the detections, and track id -> (n,) the new detections that track
        may not be linked to.
    """
    if diameter_px <= 0 or det.patch is None or not len(det.uv):
        return det, {}
    spots = predicted_in_spots(state, camera, det.uv, stamp_s, diameter_px)
    tracks = {t.track_id: t for t in state.trackers[camera].tracks}
    held = set(running_numbers(state, camera, det.uv, stamp_s, diameter_px))
    held |= {tracks[tid].marker for v in spots.values() for tid, _ in v}
    wide = set(np.flatnonzero(det.size_px > WIDE * diameter_px).tolist())
    other = state.other(camera)
    period = 1.0 / state.config.fps
    shift = np.zeros(2) if shift_px is None else np.asarray(shift_px, np.float64)
    found: dict[int, tuple[list[int], FloatArray, FloatArray]] = {}
    lined: set[int] = set()  # numbers placed by their lines alone (each in one spot at most)
    for spot in sorted({i for i, v in spots.items() if len(v) >= 2} | wide):
        members = spots.get(spot, [])
        markers = [tracks[tid].marker for tid, _ in members]
        starts = [p for _, p in members]
        if spot in wide and len(members) < MAX_TRACKS:
            extra = line_numbers(state, camera, det, spot, stamp_s, diameter_px, held, starts)
            extra = [(m, p) for m, p in extra if m not in lined]
            markers += [m for m, _ in extra]
            starts += [p for _, p in extra]
        if len(markers) < 2:
            continue
        placed = [other_place(state, other, m, stamp_s, period) for m in markers]
        if any(p is None for p in placed):
            continue  # a number the other camera does not place now cannot be checked
        partners = np.array(placed)
        moved = det._replace(uv=det.uv + shift)
        fit = refit_spot(moved, spot, np.array(starts) + shift, diameter_px, scale, threshold,
                         up)
        if fit is None:
            continue
        seen_uv, disc = fit[0] - shift, fit[1] - shift
        if not apart(seen_uv[len(members):], np.delete(det.uv, spot, axis=0), diameter_px):
            continue  # a marker only the lines put here is one the detector found beside it
        if not lines_agree(state.cameras[other], state.cameras[camera], partners, seen_uv,
                           LINE_SHARE * state.config.epipolar_px):
            continue
        lined |= set(markers[len(members):])
        found[spot] = ([tid for tid, _ in members] + [-1] * (len(markers) - len(members)),
                       seen_uv, disc)
        events.append(f'{camera}: spot at ({det.uv[spot][0]:.1f}, {det.uv[spot][1]:.1f}) px '
                      f'split at {stamp_s:.3f} s into markers {markers} where their tracks '
                      'and the other camera place them')
    if not found:
        return det, {}
    return replace_spots(det, found, diameter_px)


def replace_spots(det: Detections, found: dict[int, tuple[list[int], FloatArray, FloatArray]],
                  diameter_px: float) -> tuple[Detections, dict[int, NDArray[np.bool_]]]:
    """``det`` with each spot of ``found`` (spot -> (track ids, seen (k, 2) px, discs (k, 2)
    px)) replaced by its markers at the end (each a disc's radius of gyration for a marker of
    ``diameter_px``), and track id -> (n,) the new detections that
    track may not take (its spot's other markers)."""
    keep = np.array([i not in found for i in range(len(det.uv))])
    uv, centre = [det.uv[keep]], [(det.uv if det.centre is None else det.centre)[keep]]
    conf, size = [det.confidence[keep]], [det.size_px[keep]]
    mass = None if det.mass is None else [det.mass[keep]]
    owners: list[int] = []
    for spot, (tids, seen_uv, disc) in found.items():
        uv.append(seen_uv)
        centre.append(disc)
        conf.append(np.full(len(tids), det.confidence[spot]))
        size.append(np.full(len(tids), diameter_px / (2.0 * np.sqrt(2.0))))  # one disc's
        if mass is not None and det.mass is not None:  # the spot's markers share its mass
            mass.append(np.full(len(tids), det.mass[spot] / len(tids)))
        owners += tids
    n_kept = int(keep.sum())
    out_uv = np.concatenate(uv)
    parts = np.zeros(len(out_uv), np.bool_)
    parts[:n_kept] = False if det.parted is None else det.parted[keep]
    crowded = None if det.crowded is None else np.concatenate(
        [det.crowded[keep], np.zeros(len(owners), np.bool_)])
    barred: dict[int, NDArray[np.bool_]] = {}
    at = n_kept
    for _, (tids, _, _) in found.items():
        for j, tid in enumerate(tids):
            if tid < 0:
                continue  # a number only the other camera places: no track here yet
            bar = np.zeros(len(out_uv), np.bool_)
            bar[at:at + len(tids)] = True
            bar[at + j] = False
            barred[tid] = bar
        at += len(tids)
    out = det._replace(uv=out_uv, confidence=np.concatenate(conf), size_px=np.concatenate(size),
                       crowded=crowded, parted=None if det.parted is None else parts,
                       centre=None if det.centre is None else np.concatenate(centre),
                       mass=None if mass is None else np.concatenate(mass))
    return out, barred
