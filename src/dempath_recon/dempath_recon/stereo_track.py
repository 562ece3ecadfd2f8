"""Markers from two cameras' images: detect, track, number, check, triangulate (stream, batch).

:class:`StereoMarkerTracker` takes the frames of both cameras one at a time in arrival order
(``update(camera, stamp, jpeg)``): it decodes and detects (``detect``), links to the camera's
tracks (``track``), numbers a camera's tracks by the marker grid once a frame fits it, and
later new tracks by the other camera's epipolar lines or, for a marker that camera never saw,
by its grid point (``associate``), or, for a marker back in both cameras while neither has it
numbered, as a pair placed by the motion of its neighbours. Every numbered point is checked
against the other camera's point of the same number (epipolar line, and a 3D point the marker
can have reached since its last accepted position); a pair that fails is withheld, never
given out as the marker. Every fault is counted: undecodable images, dropped frames (a stamp
gap of more than 1.5 frame periods), frames out of stamp order, frames without any marker,
lost and re-attached markers, withheld pairs. ``update`` returns each frame as numbered on
arrival; ``release`` gives the frames out ``number_delay_frames`` later, with the numbers
their new tracks got meanwhile. :func:`track_bag` is the batch form over a bag (``update``,
``release``, ``flush``), and :func:`~dempath_recon.trajectories.triangulate_tracks`
(re-exported here) turns the numbered pixel tracks into 3D trajectories.

The tracker's parts live beside it: its state and shared helpers (``stereo_state``), the checks
on one camera's evidence (``stereo_one_camera``), the pair checks before anything is given out
(``stereo_checks``), the numbering of a marker back in both cameras as a pair
(``stereo_pairs``), the publication delay (``stereo_release``) and its records
(``stereo_records``).
"""

from __future__ import annotations

import logging
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_recon.associate import number_by_grid, on_epipolar_line, triangulate_pairs
from dempath_recon.detect import Detections, ImageDecodeError
from dempath_recon.stereo_checks import PairChecks
from dempath_recon.stereo_pairs import PairNumbering
from dempath_recon.stereo_records import CameraCounts, PixelFrame, StereoTrackConfig
from dempath_recon.stereo_release import HeldFrame, renumber
from dempath_recon.stereo_state import MAX_DEPTH_AGE_S, RECENT_S
from dempath_recon.track import UNNUMBERED
from dempath_recon.trajectories import marker_histories, triangulate_tracks
from dempath_recon.triangulate import Camera

__all__ = ['CameraCounts', 'PixelFrame', 'StereoMarkerTracker', 'StereoTrackConfig',
           'marker_histories', 'track_bag', 'triangulate_tracks']
LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]


class StereoMarkerTracker(PairChecks, PairNumbering):
    """Streaming two-camera marker pipeline.

    Args:
        cameras: ``{name: camera}`` for the two cameras (calibrated, world frame).
        config: pipeline settings.
    """

    def update(self, camera: str, stamp_s: float, jpeg: bytes | NDArray[np.uint8]) -> PixelFrame:
        """One compressed frame of ``camera``; never raises for bad images (counts them)."""
        counts = self.counts[camera]
        try:
            det = self.detector.detect_jpeg(jpeg)
        except ImageDecodeError as err:
            index = counts.frames + counts.undecodable + counts.out_of_order  # of this camera
            counts.undecodable += 1
            msg = (f'{camera} frame {index} at {stamp_s:.6f} s: {err}; skipped (undecodable '
                   f'frames so far: {counts.undecodable})')
            LOG.warning(msg)
            return PixelFrame(camera, stamp_s, np.zeros(0, np.int32), np.zeros((0, 2)),
                              np.zeros(0), (msg,))
        return self.update_detections(camera, stamp_s, det)

    def update_image(self, camera: str, stamp_s: float, image: NDArray[np.uint8]) -> PixelFrame:
        """One decoded BGR frame (full size) of ``camera``."""
        return self.update_detections(camera, stamp_s, self.detector.detect(image))

    def update_detections(self, camera: str, stamp_s: float, det: Detections) -> PixelFrame:
        """One frame's detections of ``camera``: link, number, check against the other camera.

        The returned frame's markers are -1 where a detection is not identified, or where its
        number disagrees with the other camera (off the epipolar line, or a 3D point the
        marker cannot have reached): such a point is withheld, never given out as the marker.
        """
        counts, tracker = self.counts[camera], self.trackers[camera]
        last = self._last[camera]
        if last is not None and stamp_s <= last:
            counts.out_of_order += 1
            msg = f'{camera} frame at {stamp_s:.6f} s is not after {last:.6f} s; skipped'
            LOG.warning(msg)
            return PixelFrame(camera, stamp_s, np.zeros(0, np.int32), np.zeros((0, 2)),
                              np.zeros(0), (msg,))
        events: list[str] = []
        if last is not None and stamp_s - last > 1.5 / self.config.fps:
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
        counts.lost += tracker.counts.lost - before[0]
        counts.reattached += tracker.counts.reattached - before[1]
        self._forget_refusals(camera, stamp_s)
        markers = tf.markers
        if camera not in self._grid_uv:
            markers = self._number_by_grid(camera, tf.track_ids, tf.uv, events)
        markers = self._number_new(camera, tf.track_ids, markers, tf.uv, stamp_s, events)
        markers = self._number_pairs(camera, tf.track_ids, markers, tf.uv, stamp_s, events)
        markers = self._verify(camera, tf.track_ids, markers, tf.uv, stamp_s, events)
        free_mask = self._unnumbered_tracks(camera, tf.track_ids, markers)
        free = np.flatnonzero(free_mask)
        self._free[camera] = (stamp_s, tf.track_ids[free], tf.uv[free])
        counts.tracked += int((markers >= 0).sum())
        for m, p in zip(markers, tf.uv, strict=True):
            if m >= 0:
                self.latest[camera][int(m)] = (stamp_s, p)
        frame = PixelFrame(camera, stamp_s, markers, tf.uv, tf.confidence,
                           tuple(events) + tf.events)
        self._queue.hold(frame, tf.track_ids, free_mask)
        return frame

    def release(self) -> list[PixelFrame]:
        """The frames now ``number_delay_frames`` frames old in their camera, in arrival
        order (with a delay of 0: the frame ``update`` just returned). Call it after every
        ``update``: frames older than the delay are dropped at the next ``update`` (a caller
        that only uses ``update``'s frames, like the detector node, holds nothing).

        A point that was unnumbered on arrival because its track had no number goes out with
        the number the track has now, if the track was given one since and kept its 2D links
        in the meantime (no re-attachment after that frame, which could be another marker)
        and no other point of the frame has that number. Held frames keep their stamps: the
        delay only postpones them.
        """
        return [self._amend(h) for h in self._queue.due()]

    def flush(self) -> list[PixelFrame]:
        """All frames still held (end of a recording), with the numbers known now."""
        return [self._amend(h) for h in self._queue.rest()]

    def _amend(self, held: HeldFrame) -> PixelFrame:
        frame, late = renumber(held, self.trackers[held.camera].tracks, self.config.fps)
        self.counts[held.camera].numbered_late += late
        return frame

    def _number_by_grid(self, camera: str, track_ids: NDArray[np.int64], uv: FloatArray,
                        events: list[str]) -> NDArray[np.int32]:
        """Number this camera's tracks by the projected grid, once enough detections fit it."""
        numbers, grid_uv = number_by_grid(self.cameras[camera], uv, self.config.grid,
                                          self.config.grid_gate_px)
        need = min(self.config.min_grid_markers, len(self.config.grid.points()[0]))
        found = int((numbers >= 0).sum())
        if found < need:
            events.append(f'{camera}: {found} of {len(uv)} detections fit the marker grid; '
                          f'numbering waits for {need}')
            return np.full(len(uv), UNNUMBERED, np.int32)
        for tid, m in zip(track_ids, numbers, strict=True):
            if m >= 0:
                self.trackers[camera].number(int(tid), int(m))
        self._grid_uv[camera] = dict(zip(self.config.grid.points()[0].tolist(), grid_uv,
                                         strict=True))
        self._grid_time[camera] = self._last[camera] or 0.0
        events.append(f'{camera}: {found} of {len(uv)} detections numbered by the grid')
        return numbers

    def _number_new(self, camera: str, track_ids: NDArray[np.int64], markers: NDArray[np.int32],
                    uv: FloatArray, stamp_s: float, events: list[str]) -> NDArray[np.int32]:
        """Number unnumbered tracks from the other camera's recent markers, else by the grid.

        A candidate marker must not have been seen by this camera since the track started (a
        track that ran beside marker m's own track is not m), must lie on the track's epipolar
        line, and the pair's 3D point must be one the marker can have reached; the track is
        numbered only when exactly one candidate passes, and a candidate whose epipolar line
        passes more than one unnumbered detection of this frame is no candidate. Failing that,
        a marker this camera has never seen that appears alone at its fitted grid point takes
        that number. Numbers given here are taken back if a later pair contradicts them
        (``_verify``).
        """
        markers = markers.copy()
        other = self.other(camera)
        seen = {int(m) for m in markers if m >= 0}
        starts = {t.track_id: t.history[0][0] for t in self.trackers[camera].tracks}
        todo = np.flatnonzero(markers == UNNUMBERED)
        recent = {m: p for m, (t, p) in self.latest[other].items()
                  if m not in seen and abs(t - stamp_s) <= RECENT_S}
        lines = Counter(m for k in todo for m in on_epipolar_line(
            self.cameras[camera], self.cameras[other], uv[k], recent, self.config.epipolar_px))
        for k in todo:
            tid = int(track_ids[k])
            cands = {m: p for m, p in recent.items()
                     if m not in seen and lines[m] == 1
                     and (tid, m) not in self._refused[camera]
                     and self.latest[camera].get(m, (-np.inf, None))[0] < starts.get(tid, 0.0)}
            number = self._pick(camera, tid, uv[k], cands, stamp_s, events)
            if number < 0 and starts.get(tid) == stamp_s:  # only a track's first frame
                number = self._late_grid(camera, uv, k, seen)
                if number >= 0:
                    self.counts[camera].numbered_by_grid_late += 1
                    events.append(f'{camera}: track {tid} numbered marker {number}: it appeared '
                                  'at its grid point, not seen by this camera before')
            if number < 0:
                self.counts[camera].unnumbered += 1
                continue
            self._retire(camera, number)
            self.trackers[camera].number(tid, number)
            self._late_numbered[camera].add(tid)
            markers[k] = number
            seen.add(number)
        return markers

    def _pick(self, camera: str, track_id: int, uv: FloatArray,
              candidates: dict[int, FloatArray], stamp_s: float, events: list[str]) -> int:
        """The one candidate on the track's epipolar line at a depth the marker can be at.

        Only markers with an accepted 3D position at most ``MAX_DEPTH_AGE_S`` old are
        candidates (a line alone is ambiguous along its depth). A candidate on the line whose
        3D point the marker cannot have reached is refused for this track for good: a later,
        looser gate (the marker unseen for longer) must not overrule the tightest evidence,
        which is the first.
        """
        other = self.other(camera)
        close = on_epipolar_line(self.cameras[camera], self.cameras[other], uv, candidates,
                                 self.config.epipolar_px)
        if not close:
            return UNNUMBERED
        xyz, _ = triangulate_pairs(self.cameras[camera], self.cameras[other],
                                   np.repeat(uv[None], len(close), 0),
                                   np.array([candidates[m] for m in close]))
        fits = []
        for m, x in zip(close, xyz, strict=True):
            if m in self.positions.known:
                if stamp_s - self.positions.known[m][0] > MAX_DEPTH_AGE_S:
                    continue  # no recent 3D point: nothing to check the depth along the line
                dist, allowed = self.positions.distance(m, stamp_s, x)
            else:  # never triangulated: its grid point, while that is recent and unseen here
                anchor = self._grid_anchor(camera, m, stamp_s)
                if anchor is None:
                    continue
                dist = float(np.linalg.norm(x - anchor[0]))
                allowed = anchor[1]
            if dist <= allowed:
                fits.append(m)
                continue
            self._refused[camera].add((track_id, m))
            events.append(f'{camera}: track {track_id} is not marker {m}: on its epipolar line '
                          f'but {1e3 * dist:.0f} mm from its last position (at most '
                          f'{1e3 * allowed:.0f} mm)')
        if len(fits) != 1:
            return UNNUMBERED
        self.counts[camera].numbered_by_epipolar += 1
        events.append(f'{camera}: track {track_id} numbered marker {fits[0]} by the epipolar '
                      'line')
        return fits[0]


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
    frames: list[PixelFrame] = []
    topic_cam = {f'/{n}/image_raw/compressed': n for n in cameras}
    with open_bag(bag, list(topic_cam)) as reader:
        for raw in reader.messages(list(topic_cam)):
            msg = reader.deserialize(raw)
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            if stamp < start_ns:
                continue
            tracker.update(topic_cam[raw.topic], stamp * 1e-9, bytes(msg.data))
            frames += tracker.release()
    return frames + tracker.flush(), tracker.report()
