"""Numbered pixel tracks of two cameras -> 3D marker trajectories (batch).

:func:`triangulate_tracks` turns the numbered pixel frames of
:class:`dempath_recon.tracking.stereo.StereoMarkerTracker` into 3D trajectories at the side
camera's stamps, interpolating the other camera's track to each side stamp, because
unsynchronised cameras expose at different instants (a few ms at 1 m/s is a few mm).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera, triangulate_points
from dempath_recon.tracking.associate import triangulate_pairs
from dempath_recon.tracking.records import PixelFrame

FloatArray = NDArray[np.float64]


def marker_histories(frames: list[PixelFrame], camera: str,
                     ) -> dict[int, tuple[FloatArray, FloatArray]]:
    """``{marker: (times (k,) s, uv (k, 2) px)}`` of one camera's numbered points, markers in
    the order they first appear, each one's points in the frames' order.

    One grouping of all the camera's points at once (a stable sort by number): the whole
    pass's steps ask for these histories about 25 times a pass, and a loop over every point
    cost 0.4 ms a call (session 25)."""
    mine = [f for f in frames if f.camera == camera]
    if not mine:
        return {}
    markers = np.concatenate([np.asarray(f.markers, np.int64).reshape(-1) for f in mine])
    numbered = markers >= 0
    if not numbered.any():
        return {}
    uv = np.concatenate([np.asarray(f.uv, np.float64).reshape(-1, 2) for f in mine])[numbered]
    times = np.repeat(np.array([f.stamp_s for f in mine], np.float64),
                      [len(f.markers) for f in mine])[numbered]
    markers = markers[numbered]
    order = np.argsort(markers, kind='stable')  # by number, each one's points in frame order
    numbers, starts = np.unique(markers[order], return_index=True)
    ends = np.append(starts[1:], len(order))
    first = order[starts]  # where each number first appears
    return {int(numbers[j]): (times[order[starts[j]:ends[j]]], uv[order[starts[j]:ends[j]]])
            for j in np.argsort(first, kind='stable').tolist()}


def interpolate_history(hist: tuple[FloatArray, FloatArray], t: FloatArray, max_gap_s: float,
                 ) -> FloatArray:
    """(len(t), 2) px of a track at times t, NaN where no samples within ``max_gap_s`` bracket."""
    times, uv = hist
    out = np.full((len(t), 2), np.nan)
    if len(times) < 2:
        return out
    k = np.searchsorted(times, t)
    ok = (k > 0) & (k < len(times))
    kk = np.clip(k, 1, len(times) - 1)
    ok &= (times[kk] - times[kk - 1]) <= max_gap_s
    for i in range(2):
        out[ok, i] = np.interp(t[ok], times, uv[:, i])
    return out


PAIR_GAP_FRAMES = 1.5  # the other camera's points are interpolated over gaps of at most this
# many frame periods (a frame dropped between two of its exposures) [frames]


def epipolar_to_history(cam: Camera, other_cam: Camera, uv: FloatArray,
                        other: tuple[FloatArray, FloatArray], times: FloatArray, fps: float,
                        ) -> FloatArray:
    """(k,) px: each point ``uv`` (k, 2) of ``cam`` off the epipolar line of the other
    camera's point of a marker (``other``: its history, ``marker_histories``) interpolated to
    its stamp (``times`` (k,) s, over gaps of at most ``PAIR_GAP_FRAMES``); NaN: none there."""
    ouv = interpolate_history(other, times, PAIR_GAP_FRAMES / fps)
    ok = np.isfinite(ouv).all(axis=1)
    out = np.full(len(times), np.nan)
    if ok.any():
        out[ok] = triangulate_pairs(cam, other_cam, uv[ok], ouv[ok])[1]
    return out


def paired_points(hist_a: tuple[FloatArray, FloatArray], hist_b: tuple[FloatArray, FloatArray],
                  cam_a: Camera, cam_b: Camera, fps: float,
                  ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """One marker's numbered points of camera a (``marker_histories``) with camera b's points of
    that number interpolated to their stamps (over gaps of at most 1.5 frame periods),
    triangulated: ``(times (k,) s, xyz (k, 3) m, epipolar distance (k,) px)`` of the points
    that have a partner (the whole-pass steps' 3D points of a marker)."""
    times, uv = hist_a
    uv_b = interpolate_history(hist_b, times, 1.5 / fps)
    ok = np.isfinite(uv_b).all(axis=1)
    if not ok.any():
        return times[:0], np.empty((0, 3)), np.empty(0)
    xyz, epi = triangulate_pairs(cam_a, cam_b, uv[ok], uv_b[ok])
    return times[ok], xyz, epi


def triangulate_tracks(frames: list[PixelFrame], cameras: dict[str, Camera], side: str,
                       fps: float = 50.0) -> tuple[FloatArray, NDArray[np.int32], FloatArray]:
    """3D trajectories at the ``side`` camera's stamps.

    Returns:
        ``(times (nt,) s, markers (m,), xyz (nt, m, 3) m)``, NaN where a marker is missing in
        either camera (the other camera's track is interpolated to the side stamps over gaps
        of at most 1.5 frame periods).
    """
    front = next(n for n in cameras if n != side)
    hs, hf = marker_histories(frames, side), marker_histories(frames, front)
    times = np.array(sorted({f.stamp_s for f in frames if f.camera == side}))
    markers = np.array(sorted(set(hs) & set(hf)), np.int32)
    xyz = np.full((len(times), len(markers), 3), np.nan)
    for j, m in enumerate(markers):
        us = np.full((len(times), 2), np.nan)
        idx = np.searchsorted(times, hs[int(m)][0])
        us[idx] = hs[int(m)][1]
        uf = interpolate_history(hf[int(m)], times, 1.5 / fps)
        ok = np.isfinite(us).all(1) & np.isfinite(uf).all(1)
        if ok.any():
            views = np.stack([us[ok], uf[ok]])
            xyz[ok, j] = triangulate_points([cameras[side], cameras[front]], views).xyz
    return times, markers, xyz
