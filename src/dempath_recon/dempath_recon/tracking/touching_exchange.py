"""Two markers that touched in one camera: their numbers after it kept only where the other
camera tells which track is which, else withheld.

Where two markers touch or overlap in one image (centres within ``TOUCH_SHARE`` of a
diameter), their two 2D tracks can leave the contact exchanged: the linker follows the spots,
not the markers, and one merged spot, or two that overlap, says nothing about which is which.
The frame-by-frame checks pass the exchange when the two markers part along that camera's
epipolar line of the other camera's points (session 24's census: the side camera's 7 and 12 of
a dusk render with the tool at x1.5, 4-5 px apart for six frames, then parting; after it each
side track paired with the other's front track 0.4 px off the epipolar line, and with its own
1.5 px off: 15 wrong numbers and 6 wrong 3D points, up to 24 mm off).

With the whole pass held (``StereoTrackConfig.whole_pass``), :func:`withhold_exchanged` runs at
``flush``: for every contact of two numbered markers in a camera (their points, interpolated
over gaps of up to ``GAP_FRAMES``, within ``TOUCH_SHARE`` diameters), the first
``AFTER_FRAMES`` frames after the closest approach where both are given out apart are paired
with the other camera's points of both numbers (interpolated to the stamps over 1.5 frame
periods, as :mod:`~dempath_recon.tracking.trajectories` pairs them). The numbers stay when the
pairing as numbered lies off the epipolar lines clearly less than the exchanged one (the
medians: exchanged >= ``MARGIN`` x as numbered + ``FLOOR_SHARE`` diameters): the other camera
tells them apart. Else (the exchange fits as well, or the other camera gives neither out
then) both numbers are withheld on the two tracks from the closest approach on: a wrong number
is worse than none (issue 28). A contact with a marker the other camera never numbers is left
as it is (nothing to compare with).

Two refinements (session 25, ``StereoTrackConfig.touch_wait`` and ``touch_swap``): the contact
is judged on every run of ``AFTER_FRAMES`` frames where the other camera gives a point, while
both numbers stay on the two tracks that left it, not only on the first frames (two markers
parting along the other camera's epipolar line fit both pairings until they are far apart:
heldout26's S231_asis, 9 and 14, told apart 20 frames on); and the two hypotheses are compared
once, the same margin both ways, so that tracks the other camera tells apart exchanged take
each other's number instead of being withheld.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.projection import Camera
from dempath_recon.tracking.carried_numbers import withhold_points
from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.trajectories import epipolar_to_history, marker_histories

FloatArray = NDArray[np.float64]
TOUCH_SHARE = 1.0  # two markers' centres this near touch: their tracks may exchange
# [diameters] (the census's exchange came out of 0.45-0.6; 0.5-1.25 found the same contacts
# on 18 tuning looks)
GAP_FRAMES = 2  # a number's points interpolated over at most this many missing frames to find
# a contact (two touching markers are often merged or withheld in the frames they touch)
AFTER_FRAMES = 4  # frames after the contact compared [frames] (both given out apart)
MARGIN = 2.0  # the exchanged pairing must lie this many times further off the epipolar
# lines than the numbered one ... [1] (1.5-3 decided the same on 18 tuning looks)
FLOOR_SHARE = 0.06  # ... plus this [diameters] (0.5 px at 8 px markers: centroid noise alone)


class Exchanged(NamedTuple):
    """The pass's frames after the check, and per camera how many numbered points were
    withheld and how many were given the other marker's number (``swap``)."""

    frames: list[PixelFrame]
    withheld: dict[str, int]
    swapped: dict[str, int]


def positions(frames: Sequence[PixelFrame], order: list[int],
              ) -> tuple[dict[int, FloatArray], dict[int, NDArray[np.bool_]]]:
    """Each number's point in the frames ``order`` (one camera's, in stamp order): ``{marker:
    (len(order), 2) px}`` filled over gaps of up to ``GAP_FRAMES`` frames by linear
    interpolation (NaN elsewhere), and ``{marker: (len(order),) bool}`` where it is given out."""
    pos: dict[int, FloatArray] = {}
    for p, i in enumerate(order):
        f = frames[i]
        for k, m in enumerate(f.markers.tolist()):
            if m >= 0:
                pos.setdefault(m, np.full((len(order), 2), np.nan))[p] = f.uv[k]
    given = {m: np.asarray(np.isfinite(uv).all(axis=1), bool) for m, uv in pos.items()}
    for m, uv in pos.items():
        have = np.flatnonzero(given[m])
        for a, b in zip(have[:-1].tolist(), have[1:].tolist(), strict=True):
            if 1 < b - a <= GAP_FRAMES + 1:
                share = (np.arange(a + 1, b) - a) / (b - a)
                uv[a + 1:b] = uv[a] + share[:, None] * (uv[b] - uv[a])
    return pos, given


def told_apart(own: FloatArray, exchanged: FloatArray, diameter_px: float) -> bool:
    """Whether the pairing as numbered (``own``: its points' epipolar distances [px]) beats
    the exchanged one (``exchanged``) by the margin; False when either has none."""
    if not (np.isfinite(own).any() and np.isfinite(exchanged).any()):
        return False
    return bool(np.nanmedian(exchanged) >= MARGIN * np.nanmedian(own)
                + FLOOR_SHARE * diameter_px)


def track_of(frame: PixelFrame, track_ids: NDArray[np.int64], marker: int) -> int:
    """The 2D track giving ``marker`` out in ``frame`` (-1: not given out)."""
    k = np.flatnonzero(frame.markers == marker)
    return int(track_ids[int(k[0])]) if len(k) else -1


def windows(after: NDArray[np.int64], returned: NDArray[np.bool_], wait: bool,
            ) -> list[NDArray[np.int64]]:
    """The runs of after-frames a contact is judged on, in order: without ``wait`` the first
    ``AFTER_FRAMES`` of ``after`` (the frames after the contact where both are given out apart);
    with it, ``after``'s frames where the other camera gives a point of either marker
    (``returned``), cut into consecutive runs of ``AFTER_FRAMES`` (the last may be shorter).
    ``after`` and ``returned``: (n,) frame indices and flags."""
    if not wait:
        return [after[:AFTER_FRAMES]]
    back = after[returned]
    return [back[s:s + AFTER_FRAMES] for s in range(0, len(back), AFTER_FRAMES)]


def withhold_exchanged(frames: Sequence[PixelFrame], track_ids: Sequence[NDArray[np.int64]],
                       cameras: dict[str, Camera], diameter_px: dict[str, float], fps: float,
                       wait: bool = False, swap: bool = False) -> Exchanged:
    """The pass's frames with both numbers of every contact the other camera does not tell
    apart withheld after it (the module's rule); nothing changes without two cameras and a
    marker size in each (``diameter_px`` [px] by camera; ``track_ids``: each frame's (k,)
    tracks; ``fps`` [1/s]). ``wait``: judge each contact on every run of ``AFTER_FRAMES``
    frames where the other camera gives a point, while both numbers stay on the two tracks
    that left the contact, and keep the numbers when any run tells the tracks apart
    (:func:`windows`). ``swap``: where the other camera tells them apart exchanged, the two
    numbers are exchanged on the two tracks from the contact on instead of withheld
    (:func:`decide`).
    """
    names = sorted(cameras)
    if len(names) != 2 or not all(diameter_px.get(c, 0.0) > 0 for c in names):
        return apply(frames, set(), {})
    hist = {c: marker_histories(list(frames), c) for c in names}
    drop: set[tuple[int, int]] = set()
    moved: dict[tuple[int, int], int] = {}
    for cam in names:
        other = names[1 - names.index(cam)]
        size = diameter_px[cam]
        order = sorted((i for i, f in enumerate(frames) if f.camera == cam),
                       key=lambda i: frames[i].stamp_s)
        times = np.array([frames[i].stamp_s for i in order])
        pos, given = positions(frames, order)
        numbers = sorted(m for m in pos if m in hist[other])
        for a, m in enumerate(numbers):
            for n in numbers[a + 1:]:
                dist = np.linalg.norm(pos[m] - pos[n], axis=1)
                close = np.flatnonzero(dist < TOUCH_SHARE * size)  # NaN compares False
                for contact in np.split(close, np.flatnonzero(np.diff(close) > GAP_FRAMES) + 1):
                    if not len(contact):
                        continue
                    nearest = int(contact[int(np.argmin(dist[contact]))])
                    after = np.array([q for q in range(nearest + 1, len(order))
                                      if given[m][q] and given[n][q]
                                      and dist[q] >= TOUCH_SHARE * size], int)
                    if not len(after):
                        continue
                    first = order[int(after[0])]
                    tracks = {x: track_of(frames[first], track_ids[first], x) for x in (m, n)}
                    if wait:  # the two tracks of the first frame after the contact, on
                        after = after[[all(track_of(frames[order[q]], track_ids[order[q]], x)
                                           == t for x, t in tracks.items())
                                       for q in after.tolist()]]
                    px = {(x, y): epipolar_to_history(cameras[cam], cameras[other],
                                                      pos[x][after], hist[other][y],
                                                      times[after], fps)
                          for x in (m, n) for y in (m, n)}
                    returned = np.asarray(np.isfinite(np.stack(list(px.values()))).any(axis=0),
                                          bool)
                    verdict = decide(px, m, n, windows(np.arange(len(after)), returned, wait),
                                     size, swap)
                    if verdict == 'kept':
                        continue
                    for i in order[nearest + 1:]:
                        for k in np.flatnonzero(np.isin(track_ids[i], list(tracks.values()))
                                                & np.isin(frames[i].markers, (m, n))).tolist():
                            if verdict == 'swapped':
                                moved[i, k] = n if int(frames[i].markers[k]) == m else m
                            else:
                                drop.add((i, k))
    return apply(frames, drop, moved)


def decide(px: dict[tuple[int, int], FloatArray], m: int, n: int,
           runs: list[NDArray[np.int64]], size: float, swap: bool) -> str:
    """``'kept'`` when a run of ``runs`` (in order) tells the tracks apart as numbered,
    ``'swapped'`` (with ``swap``) when one tells them apart exchanged first (the same margin
    the other way: one comparison of the two hypotheses), else ``'withheld'``. ``px``: the
    epipolar distances [px] of each number's points (first key) to each number's points in
    the other camera (second key), at the after-frames."""
    for r in runs:
        own = np.concatenate([px[m, m][r], px[n, n][r]])
        exchanged = np.concatenate([px[m, n][r], px[n, m][r]])
        if told_apart(own, exchanged, size):
            return 'kept'
        if swap and told_apart(exchanged, own, size):
            return 'swapped'
    return 'withheld'


def apply(frames: Sequence[PixelFrame], drop: set[tuple[int, int]],
          moved: dict[tuple[int, int], int]) -> Exchanged:
    """``frames`` with the points ``drop`` withheld and the points ``moved`` given their new
    numbers (withheld instead where another point of the frame keeps that number), each with
    an event, counted per camera."""
    out = list(frames)
    drop = set(drop)
    swapped = {f.camera: 0 for f in frames}
    by_frame: dict[int, dict[int, int]] = {}
    for (i, k), new in moved.items():
        if (i, k) not in drop:
            by_frame.setdefault(i, {})[k] = new
    for i, change in by_frame.items():
        f = out[i]
        markers = f.markers.copy()
        markers[list(change)] = list(change.values())
        events = list(f.events)
        for k, new in change.items():
            if int((markers == new).sum()) > 1:  # another point keeps it: neither is sure
                drop.add((i, k))
                continue
            events.append(f'{f.camera}: marker {int(f.markers[k])} renumbered {new} at '
                          f"{f.stamp_s:.3f} s: its track touched marker {new}'s, and the "
                          'other camera tells them apart exchanged after it')
            swapped[f.camera] += 1
        for k in change:
            if (i, k) in drop:
                markers[k] = f.markers[k]  # withheld below under its old number
        out[i] = f._replace(markers=markers, events=tuple(events))
    held = withhold_points(out, drop, "its track touched another marker's, and the other "
                           'camera does not tell them apart after it')
    return Exchanged(held.frames, held.withheld, swapped)
