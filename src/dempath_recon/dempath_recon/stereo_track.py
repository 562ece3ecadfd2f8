"""Markers from two cameras' images: detect, track, number, and triangulate (stream and batch).

:class:`StereoMarkerTracker` takes the frames of both cameras one at a time in arrival order
(``update(camera, stamp, jpeg)``): it decodes and detects (``detect``), links to the camera's
tracks (``track``), numbers the first frame by the marker grid and later new tracks by the
other camera's epipolar lines (``associate``), and counts every fault: undecodable images,
dropped frames (a stamp gap of more than 1.5 frame periods), frames out of stamp order, frames
without any marker, lost and re-attached markers, and pairs that disagree with the epipolar
geometry. :func:`track_bag` is the batch form over a bag, and :func:`triangulate_tracks` turns
the numbered pixel tracks into 3D trajectories, interpolating the front camera's track to each
side frame's stamp because unsynchronised cameras expose at different instants.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.associate import (
    MarkerGrid,
    epipolar_distance,
    number_by_epipolar,
    number_by_grid,
)
from dempath_recon.detect import (
    Detections,
    DetectorConfig,
    ImageDecodeError,
    MarkerDetector,
)
from dempath_recon.track import UNNUMBERED, MarkerTracker, TrackerConfig
from dempath_recon.triangulate import Camera, triangulate_points

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
RECENT_S = 0.05  # the other camera's position of a marker counts for numbering this long [s]


@dataclass(frozen=True)
class StereoTrackConfig:
    """Settings of the two-camera marker pipeline.

    Attributes:
        detector: detector settings.
        tracker: linker settings.
        grid: the initial marker grid.
        fps: nominal frame rate [1/s] (dropped frames are gaps above 1.5 periods).
        epipolar_px: largest distance to the epipolar line of a numbered pair [px].
    """

    detector: DetectorConfig = field(default_factory=DetectorConfig)
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    grid: MarkerGrid = field(default_factory=MarkerGrid)
    fps: float = 50.0
    epipolar_px: float = 4.0


class PixelFrame(NamedTuple):
    """Numbered marker pixels of one camera frame (what a PixelPoints message carries)."""

    camera: str
    stamp_s: float
    markers: NDArray[np.int32]  # (k,) marker numbers, -1 not identified
    uv: FloatArray  # (k, 2) px
    confidence: FloatArray  # (k,)
    events: tuple[str, ...]


@dataclass
class CameraCounts:
    """What happened to one camera's frames (the run report's rows)."""

    frames: int = 0
    undecodable: int = 0
    dropped: int = 0
    out_of_order: int = 0
    no_marker: int = 0
    detected: int = 0
    tracked: int = 0
    lost: int = 0
    reattached: int = 0
    numbered_by_epipolar: int = 0
    unnumbered: int = 0
    epipolar_conflicts: int = 0
    gaps_s: list[tuple[float, float]] = field(default_factory=list)


class StereoMarkerTracker:
    """Streaming two-camera marker pipeline.

    Args:
        cameras: ``{name: camera}`` for the two cameras (calibrated, world frame).
        config: pipeline settings.
    """

    def __init__(self, cameras: dict[str, Camera], config: StereoTrackConfig | None = None,
                 ) -> None:
        if len(cameras) != 2:
            raise ValueError(f'cameras: need exactly two, got {sorted(cameras)}')
        self.cameras = cameras
        self.config = config or StereoTrackConfig()
        self.detector = MarkerDetector(self.config.detector)
        self.trackers = {n: MarkerTracker(self.config.tracker) for n in cameras}
        self.counts = {n: CameraCounts() for n in cameras}
        self.latest: dict[str, dict[int, tuple[float, FloatArray]]] = {n: {} for n in cameras}
        self._last: dict[str, float | None] = dict.fromkeys(cameras)

    def other(self, camera: str) -> str:
        """The other camera's name."""
        return next(n for n in self.cameras if n != camera)

    def update(self, camera: str, stamp_s: float, jpeg: bytes | NDArray[np.uint8]) -> PixelFrame:
        """One compressed frame of ``camera``; never raises for bad images (counts them)."""
        counts = self.counts[camera]
        try:
            det = self.detector.detect_jpeg(jpeg)
        except ImageDecodeError as err:
            counts.undecodable += 1
            msg = f'{camera} frame at {stamp_s:.6f} s: {err}; skipped'
            LOG.warning(msg)
            return PixelFrame(camera, stamp_s, np.zeros(0, np.int32), np.zeros((0, 2)),
                              np.zeros(0), (msg,))
        return self.update_detections(camera, stamp_s, det)

    def update_image(self, camera: str, stamp_s: float, image: NDArray[np.uint8]) -> PixelFrame:
        """One decoded BGR frame (full size) of ``camera``."""
        return self.update_detections(camera, stamp_s, self.detector.detect(image))

    def update_detections(self, camera: str, stamp_s: float, det: Detections) -> PixelFrame:
        """One frame's detections of ``camera``: link, number, count."""
        counts, tracker = self.counts[camera], self.trackers[camera]
        last = self._last[camera]
        if last is not None and stamp_s <= last:
            counts.out_of_order += 1
            msg = f'{camera} frame at {stamp_s:.6f} s is not after {last:.6f} s; skipped'
            LOG.warning(msg)
            return PixelFrame(camera, stamp_s, np.zeros(0, np.int32), np.zeros((0, 2)),
                              np.zeros(0), (msg,))
        events: list[str] = []
        if last is None:
            numbers, _ = number_by_grid(self.cameras[camera], det.uv, self.config.grid)
            ok = numbers >= 0
            tracker.seed(det.uv[ok], numbers[ok], stamp_s - 1e-6)
            events.append(f'{camera}: {int(ok.sum())} of {len(det.uv)} detections numbered '
                          'by the grid')
        elif stamp_s - last > 1.5 / self.config.fps:
            missed = round((stamp_s - last) * self.config.fps) - 1
            counts.dropped += max(missed, 1)
            counts.gaps_s.append((last, stamp_s))
            events.append(f'{camera}: {max(missed, 1)} frame(s) missing before {stamp_s:.3f} s')
        self._last[camera] = stamp_s
        counts.frames += 1
        counts.no_marker += int(len(det.uv) == 0)
        before = (tracker.counts.lost, tracker.counts.reattached)
        tf = tracker.update(stamp_s, det)
        counts.detected += len(det.uv)
        counts.tracked += int((tf.markers >= 0).sum())
        counts.lost += tracker.counts.lost - before[0]
        counts.reattached += tracker.counts.reattached - before[1]
        markers = self._number_new(camera, tf.track_ids, tf.markers, tf.uv, stamp_s, events)
        self._check_epipolar(camera, markers, tf.uv, stamp_s)
        for m, p in zip(markers, tf.uv, strict=True):
            if m >= 0:
                self.latest[camera][int(m)] = (stamp_s, p)
        return PixelFrame(camera, stamp_s, markers, tf.uv, tf.confidence,
                          tuple(events) + tf.events)

    def _number_new(self, camera: str, track_ids: NDArray[np.int64], markers: NDArray[np.int32],
                    uv: FloatArray, stamp_s: float, events: list[str]) -> NDArray[np.int32]:
        """Number unnumbered tracks from the other camera's recent markers (epipolar lines)."""
        markers = markers.copy()
        other = self.other(camera)
        seen = {int(m) for m in markers if m >= 0}
        for k in np.flatnonzero(markers == UNNUMBERED):
            cands = {m: p for m, (t, p) in self.latest[other].items()
                     if m not in seen and abs(t - stamp_s) <= RECENT_S}
            number = number_by_epipolar(self.cameras[camera], self.cameras[other], uv[k], cands,
                                        self.config.epipolar_px)
            if number < 0:
                self.counts[camera].unnumbered += 1
                continue
            self._retire(camera, number)
            self.trackers[camera].number(int(track_ids[k]), number)
            markers[k] = number
            seen.add(number)
            self.counts[camera].numbered_by_epipolar += 1
            events.append(f'{camera}: track {int(track_ids[k])} numbered marker {number} by '
                          'the epipolar line')
        return markers

    def _retire(self, camera: str, number: int) -> None:
        """Drop the lost track that held ``number`` (its marker came back as a new track)."""
        tracker = self.trackers[camera]
        tracker.tracks = [t for t in tracker.tracks if not (t.lost and t.marker == number)]

    def _check_epipolar(self, camera: str, markers: NDArray[np.int32], uv: FloatArray,
                        stamp_s: float) -> None:
        other = self.other(camera)
        seen = self.latest[other]
        pairs = [(int(m), p, seen[int(m)][1]) for m, p in zip(markers, uv, strict=True)
                 if m >= 0 and int(m) in seen
                 and abs(seen[int(m)][0] - stamp_s) <= 1.0 / self.config.fps]
        if not pairs:
            return
        d = np.diag(epipolar_distance(self.cameras[camera], self.cameras[other],
                                      np.array([p[1] for p in pairs]),
                                      np.array([p[2] for p in pairs])))
        for (m, _, _), dist in zip(pairs, d, strict=True):
            if dist > 3 * self.config.epipolar_px:
                self.counts[camera].epipolar_conflicts += 1
                LOG.warning('%s marker %d at %.3f s is %.1f px off the epipolar line', camera, m,
                            stamp_s, dist)

    def report(self) -> dict[str, Any]:
        """Counts per camera, and the stamp gaps where frames were missing."""
        return {n: {k: v for k, v in vars(c).items()} for n, c in self.counts.items()}


def track_bag(bag: Path, cameras: dict[str, Camera], config: StereoTrackConfig | None = None,
              start_ns: int = 0) -> tuple[list[PixelFrame], dict[str, Any]]:
    """Batch form over a bag's ``/<cam>/image_raw/compressed`` topics (bag order).

    Args:
        bag: the bag folder.
        cameras: ``{name: camera}``; their names give the topics.
        config: pipeline settings.
        start_ns: ignore frames stamped before this (e.g. the calibration segment) [ns].
    """
    from dempath.bagio import open_bag

    tracker = StereoMarkerTracker(cameras, config)
    frames = []
    topic_cam = {f'/{n}/image_raw/compressed': n for n in cameras}
    with open_bag(bag, list(topic_cam)) as reader:
        for raw in reader.messages(list(topic_cam)):
            msg = reader.deserialize(raw)
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            if stamp < start_ns:
                continue
            frames.append(tracker.update(topic_cam[raw.topic], stamp * 1e-9, bytes(msg.data)))
    return frames, tracker.report()


def marker_histories(frames: list[PixelFrame], camera: str,
                     ) -> dict[int, tuple[FloatArray, FloatArray]]:
    """``{marker: (times (k,) s, uv (k, 2) px)}`` of one camera's numbered points."""
    out: dict[int, list[tuple[float, float, float]]] = {}
    for f in frames:
        if f.camera != camera:
            continue
        for m, p in zip(f.markers, f.uv, strict=True):
            if m >= 0:
                out.setdefault(int(m), []).append((f.stamp_s, float(p[0]), float(p[1])))
    return {m: (np.array([r[0] for r in rows]), np.array([r[1:] for r in rows]))
            for m, rows in out.items()}


def _interpolate(hist: tuple[FloatArray, FloatArray], t: FloatArray, max_gap_s: float,
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
        uf = _interpolate(hf[int(m)], times, 1.5 / fps)
        ok = np.isfinite(us).all(1) & np.isfinite(uf).all(1)
        if ok.any():
            views = np.stack([us[ok], uf[ok]])
            xyz[ok, j] = triangulate_points([cameras[side], cameras[front]], views).xyz
    return times, markers, xyz
