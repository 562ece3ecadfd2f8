"""Numbers carried over a break of a 2D track withheld unless the other camera confirms them.

A 2D track carries its number from link to link. Where the link breaks (a gap of more than 1.5
frame periods: the spot was lost and re-attached; or a jump off the constant-velocity
prediction: :func:`~dempath_recon.tracking.whole_pass.smooth_pieces`), nothing in this camera
says the spot after the break is the marker before it: where markers bunch in front of the
tine and take turns being buried, the re-attached spot is often the neighbour that came up
beside the buried marker (session 24's census of 29 switches on 16 burnt tiny_long looks: 10
were such carried pieces, their own marker at 0.0-0.4 visible share, the neighbour within a
diameter or two, and the other camera not giving the number at those instants).

With the whole pass held (``StereoTrackConfig.whole_pass``) and ``carried_confirm`` on (off by
default: it did not carry over to looks it was not tuned on), :func:`withhold_carried` runs at
``flush`` after the pass audit. A piece of a camera's track after its first (the track's
pieces past a break) that carries a number is **ambiguous** when another marker could be the
spot it starts at: another spot of that frame, or a point of another number in the camera's
frames up to ``CROWD_FRAMES`` either side, lies within ``CROWD_SHARE`` marker diameters of it
(:func:`crowded`). An ambiguous piece keeps its number only when the other camera confirms it
at one of its points at least: that camera's point of the same number, interpolated to the
point's stamp over at most 1.5 frame periods (as :mod:`~dempath_recon.tracking.trajectories`
pairs them), lies within ``CONFIRM_SHARE`` of a marker's diameter of the point's epipolar line.
Else the piece's points of that number are withheld: a wrong number is worse than none (issue
28), and a marker the other camera does not see after the break is one this camera cannot
number alone. Decisions are made on the frames as they come in, then applied, so one
camera's withholding does not take away the other's confirmation. A piece with no other
marker near its start keeps its number: a marker only one camera sees after a gap (noisy
images break both cameras' tracks often) is numbered right there (without the crowding test,
the bundled render's noisy variation lost 2 points of its numbered-right share).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.projection import Camera
from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.trajectories import epipolar_to_history, marker_histories
from dempath_recon.tracking.whole_pass import smooth_pieces

FloatArray = NDArray[np.float64]
UNNUMBERED = -1
CONFIRM_SHARE = 0.35  # a confirming pair's epipolar distance, x the marker's diameter [px/px]
# (about 3 px at 8 px markers: the pair's centroid noise and the cameras' unsynchronised
# stamps; chosen on 16 burnt looks: 0.25 and 0.35 removed 10 of 29 switches, 0.45 only 7)
CROWD_SHARE = 2.0  # another marker this near the spot a piece starts at may be that spot
# [diameters] (touching markers, plus the diameter either may move over a short gap; chosen on
# 16 burnt looks: 1.5 removed 2 of 29 switches, 2.0 9, 3.0 9 at more cost)
CROWD_FRAMES = 2  # frames either side whose points of other numbers count as near [frames]
# (a buried neighbour is not seen in the frame itself but was, or will be, a frame or two away)


class Withheld(NamedTuple):
    """Frames with some numbered points withheld, and per camera how many were."""

    frames: list[PixelFrame]
    withheld: dict[str, int]


def withhold_points(frames: Sequence[PixelFrame], points: Iterable[tuple[int, int]], why: str,
                    ) -> Withheld:
    """``frames`` with the numbered points ``points`` (frame index, place in the frame)
    unnumbered, each with an event of its frame (``<camera>: marker <m> withheld at <t> s:
    <why>``), counted per camera."""
    out = list(frames)
    withheld = {f.camera: 0 for f in frames}
    for i, k in sorted(set(points)):
        f = out[i]
        markers = f.markers.copy()
        m = int(markers[k])
        markers[k] = UNNUMBERED
        event = f'{f.camera}: marker {m} withheld at {f.stamp_s:.3f} s: {why}'
        out[i] = f._replace(markers=markers, events=(*f.events, event))
        withheld[f.camera] += 1
    return Withheld(out, withheld)


def track_points(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                 ) -> dict[tuple[str, int], list[tuple[int, int]]]:
    """``{(camera, track id): [(frame index, place in the frame), ...]}`` in stamp order."""
    tracks: dict[tuple[str, int], list[tuple[int, int]]] = {}
    for i, (f, ids) in enumerate(zip(frames, track_ids, strict=True)):
        for k, tid in enumerate(ids.tolist()):
            tracks.setdefault((f.camera, int(tid)), []).append((i, k))
    for where in tracks.values():
        where.sort(key=lambda w: frames[w[0]].stamp_s)
    return tracks


def crowded(frames: Sequence[PixelFrame], order: list[int], at: tuple[int, int], marker: int,
            within_px: float) -> bool:
    """Whether another marker may be the point ``at`` (frame index, place in the frame) of
    ``marker``: another spot of its frame, or a point of another number in the frames of
    ``order`` (its camera's frame indices in stamp order) up to ``CROWD_FRAMES`` either side,
    lies within ``within_px`` of it."""
    i, k = at
    uv = frames[i].uv[k]
    others = np.delete(frames[i].uv, k, axis=0)
    if len(others) and float(np.linalg.norm(others - uv, axis=1).min()) < within_px:
        return True
    pos = order.index(i)
    for j in order[max(0, pos - CROWD_FRAMES):pos + CROWD_FRAMES + 1]:
        f = frames[j]
        near = (f.markers >= 0) & (f.markers != marker)
        if near.any() and float(np.linalg.norm(f.uv[near] - uv, axis=1).min()) < within_px:
            return True
    return False


def confirmed(cam: Camera, other_cam: Camera, times: FloatArray, uv: FloatArray,
              other: tuple[FloatArray, FloatArray] | None, within_px: float, fps: float,
              ) -> bool:
    """Whether the other camera's points of a marker (``other``: its history, times (j,) s
    and uv (j, 2) px; None: it never gave the marker) confirm any of the points ``uv`` (k, 2)
    px at ``times`` (k,) s: a partner within ``within_px`` of its epipolar line."""
    if other is None:
        return False
    return bool((epipolar_to_history(cam, other_cam, uv, other, times, fps) <= within_px).any())


def withhold_carried(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                     cameras: dict[str, Camera], diameter_px: dict[str, float], fps: float,
                     ) -> Withheld:
    """The pass's frames with every number carried over a break of its 2D track where
    another marker was near, and never confirmed by the other camera on the piece after the
    break, withheld (the module's rule).

    Args:
        frames: every frame of the pass (both cameras).
        track_ids: per frame, (k,) the track of each point.
        cameras: ``{name: camera}`` of the two cameras.
        diameter_px: ``{camera: a marker's diameter in its image [px]}``.
        fps: the frame rate [1/s].
    """
    names = sorted(cameras)
    if len(names) != 2 or not all(diameter_px.get(c, 0.0) > 0 for c in names):
        return withhold_points(frames, [], '')
    hist = {c: marker_histories(list(frames), c) for c in names}
    order = {c: sorted((i for i, f in enumerate(frames) if f.camera == c),
                       key=lambda i: frames[i].stamp_s) for c in names}
    drop: list[tuple[int, int]] = []
    for (cam, _), where in track_points(frames, track_ids).items():
        other = names[1 - names.index(cam)]
        times = np.array([frames[i].stamp_s for i, _ in where])
        uv = np.array([frames[i].uv[k] for i, k in where], np.float64).reshape(-1, 2)
        numbers = np.array([int(frames[i].markers[k]) for i, k in where], np.int64)
        for piece in smooth_pieces(times, uv, fps)[1:]:  # the pieces past a break
            for m in sorted(set(numbers[piece].tolist()) - {UNNUMBERED}):
                sel = piece[numbers[piece] == m]
                if not crowded(frames, order[cam], where[int(sel[0])], m,
                               CROWD_SHARE * diameter_px[cam]):
                    continue
                if confirmed(cameras[cam], cameras[other], times[sel], uv[sel],
                             hist[other].get(m), CONFIRM_SHARE * diameter_px[cam], fps):
                    continue
                drop += [where[j] for j in sel.tolist()]
    return withhold_points(frames, drop, 'carried over a break of its 2D track, the other '
                           'camera never confirms it after the break')
