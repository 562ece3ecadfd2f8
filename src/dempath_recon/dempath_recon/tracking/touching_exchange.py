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
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.projection import Camera
from dempath_recon.tracking.carried_numbers import Withheld, withhold_points
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
                       wait: bool = False) -> Withheld:
    """The pass's frames with both numbers of every contact the other camera does not tell
    apart withheld after it (the module's rule); nothing changes without two cameras and a
    marker size in each (``diameter_px`` [px] by camera; ``track_ids``: each frame's (k,)
    tracks; ``fps`` [1/s]). ``wait``: judge each contact on every run of ``AFTER_FRAMES``
    frames where the other camera gives a point, while both numbers stay on the two tracks
    that left the contact, and keep the numbers when any run tells the tracks apart
    (:func:`windows`).
    """
    names = sorted(cameras)
    if len(names) != 2 or not all(diameter_px.get(c, 0.0) > 0 for c in names):
        return withhold_points(frames, [], '')
    hist = {c: marker_histories(list(frames), c) for c in names}
    drop: set[tuple[int, int]] = set()
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
                    runs = windows(np.arange(len(after)), returned, wait)
                    if any(told_apart(np.concatenate([px[m, m][r], px[n, n][r]]),
                                      np.concatenate([px[m, n][r], px[n, m][r]]), size)
                           for r in runs):
                        continue
                    for i in order[nearest + 1:]:
                        for k in np.flatnonzero(np.isin(track_ids[i], list(tracks.values()))
                                                & np.isin(frames[i].markers, (m, n))).tolist():
                            drop.add((i, k))
    return withhold_points(frames, drop, "its track touched another marker's, and the other "
                           'camera does not tell them apart after it')
