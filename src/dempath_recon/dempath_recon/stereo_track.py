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
"""

from __future__ import annotations

import logging
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_recon.associate import (
    MarkerPositions,
    back_project,
    depth,
    epipolar_distance,
    number_by_grid,
    on_epipolar_line,
    triangulate_pairs,
)
from dempath_recon.detect import (
    Detections,
    ImageDecodeError,
    MarkerDetector,
)
from dempath_recon.stereo_records import CameraCounts, PixelFrame, StereoTrackConfig
from dempath_recon.stereo_release import HeldFrame, ReleaseQueue, renumber
from dempath_recon.track import UNNUMBERED, MarkerTracker
from dempath_recon.trajectories import marker_histories, triangulate_tracks
from dempath_recon.triangulate import Camera

__all__ = ['CameraCounts', 'PixelFrame', 'StereoMarkerTracker', 'StereoTrackConfig',
           'marker_histories', 'track_bag', 'triangulate_tracks']
LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
RECENT_S = 0.05  # the other camera's position of a marker counts for numbering this long [s]
ALONE_RATIO = 3.0  # a re-found spot is kept on one camera's evidence when every other marker
# this camera does not see now would have had to move at least this many times faster to be there
MIN_SPEED_PX_S = 50.0  # speed floor of that comparison: a pixel a frame at 50 FPS [px/s]
CARRY_FLOOR_M = 0.003  # nearest-marker comparison of ``_only_marker``: distances below this
# (a few times the triangulation noise, ~1 mm RMS) count as this [m]
MAX_DEPTH_AGE_S = 0.06  # a 3D point older than this (three frames) no longer bounds the depth
# along an epipolar line usefully (the gate has grown to 0.13 m, several marker pitches)


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
        self.positions = MarkerPositions(self.config.position_gate_m, self.config.max_speed_m_s)
        self._last: dict[str, float | None] = dict.fromkeys(cameras)
        self._grid_uv: dict[str, dict[int, FloatArray]] = {}  # the fitted grid, per camera
        self._late_numbered: dict[str, set[int]] = {n: set() for n in cameras}  # track ids
        self._refused: dict[str, set[tuple[int, int]]] = {n: set() for n in cameras}
        self._grid_time: dict[str, float] = {}  # stamp of the frame each camera's grid fit
        # withheld points of unconfirmed re-attachments: marker -> (stamp s, (2,) px)
        self._pending: dict[str, dict[int, tuple[float, FloatArray]]] = {n: {} for n in cameras}
        # each camera's last frame's unnumbered tracks: (stamp s, track ids (k,), px (k, 2))
        self._free: dict[str, tuple[float, NDArray[np.int64], FloatArray] | None] = \
            dict.fromkeys(cameras)
        self._queue = ReleaseQueue(cameras, self.config.number_delay_frames)

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

    def _unnumbered_tracks(self, camera: str, track_ids: NDArray[np.int64],
                           markers: NDArray[np.int32]) -> NDArray[np.bool_]:
        """(k,) whether each detection is unnumbered and so is its track (not a withheld
        point of a numbered track)."""
        numbered = {t.track_id for t in self.trackers[camera].tracks if t.marker >= 0}
        return np.array([m == UNNUMBERED and int(t) not in numbered
                         for t, m in zip(track_ids, markers, strict=True)], bool)

    def _number_pairs(self, camera: str, track_ids: NDArray[np.int64],
                      markers: NDArray[np.int32], uv: FloatArray, stamp_s: float,
                      events: list[str]) -> NDArray[np.int32]:
        """Number an unnumbered track of each camera together, as the one missing marker
        their pair can be.

        A marker that comes back in both cameras while neither has it numbered cannot be
        numbered by the other camera's line (each waits for the other). Here an unnumbered
        track of this camera and one of the other camera's last frame (at most one frame
        period old) are a pair when each is the other's only unnumbered point within
        ``epipolar_px`` of its epipolar line; the pair's 3D point is given the number of the
        marker, among those numbered in neither camera now, that ``_only_marker`` finds.
        Both tracks take the number (and lose it if a later pair check contradicts it), and
        the other camera's point becomes its latest, so ``_verify`` checks the pair and
        records the 3D point at once.
        """
        other = self.other(camera)
        free = self._free[other]
        if free is None or abs(free[0] - stamp_s) > 1.0 / self.config.fps or not len(free[1]):
            return markers
        t_o, o_ids, o_uv = free
        o_numbered = {t.track_id for t in self.trackers[other].tracks if t.marker >= 0}
        keep = [j for j, tid in enumerate(o_ids.tolist()) if tid not in o_numbered]
        mine = np.flatnonzero(self._unnumbered_tracks(camera, track_ids, markers))
        if not keep or not len(mine):
            return markers
        cam, cam_o = self.cameras[camera], self.cameras[other]
        close = epipolar_distance(cam, cam_o, uv[mine], o_uv[keep]) <= self.config.epipolar_px
        taken = {int(m) for m in markers if m >= 0} | {
            m for m, (t, _) in self.latest[other].items() if abs(t - stamp_s) <= RECENT_S}
        missing = [m for m in self.config.grid.points()[0].tolist() if m not in taken]
        markers = markers.copy()
        for a, k in enumerate(mine.tolist()):
            js = np.flatnonzero(close[a])
            if len(js) != 1 or close[:, js[0]].sum() != 1:
                continue
            j = keep[int(js[0])]
            tid, tid_o = int(track_ids[k]), int(o_ids[j])
            xyz, _ = triangulate_pairs(cam, cam_o, uv[k][None], o_uv[j][None])
            number = self._only_marker(xyz[0], stamp_s, missing)
            if number < 0 or (tid, number) in self._refused[camera] \
                    or (tid_o, number) in self._refused[other]:
                continue
            for c, t in ((camera, tid), (other, tid_o)):
                self._retire(c, number)
                self.trackers[c].number(t, number)
                self._late_numbered[c].add(t)
            self.latest[other][number] = (t_o, o_uv[j])
            self.counts[camera].numbered_by_pair += 1
            events.append(f'{camera}: track {tid} and {other} track {tid_o} numbered marker '
                          f'{number} as a pair: no other missing marker can be there')
            markers[k] = number
            missing.remove(number)
        return markers

    def _only_marker(self, xyz: FloatArray, stamp_s: float, missing: list[int]) -> int:
        """The one marker of ``missing`` that a 3D point can be, else -1.

        Each missing marker is placed where the bed has carried it since its last accepted 3D
        position (``MarkerPositions.carried``: moved as its nearest tracked neighbours moved;
        a marker never triangulated starts from its fitted grid point when the grid was
        fitted). The point is the nearest such marker's when it lies within what the marker
        can have reached (``position_gate_m + max_speed_m_s x dt``) and every other missing
        marker is at least ``ALONE_RATIO`` times as far (at least ``CARRY_FLOOR_M``). A missing
        marker that cannot be placed (no position, or no neighbour tracked across its gap)
        could be anywhere (-1). Its last position alone is not enough: the bed carries a
        covered marker 50 mm in half a second, to where a neighbour was lost shortly before
        (measured on the bundled render: marker 8 back 13 mm from 9's last point, 50 mm from
        its own; carried, 4.5 mm from 8 and 25 mm from 9).
        """
        near_s, ages = 1.5 / self.config.fps, []
        for m in missing:
            anchor = self._grid_point(m)
            at = self.positions.carried(m, stamp_s, near_s, MAX_DEPTH_AGE_S, anchor)
            if at is None:
                return UNNUMBERED
            since = self.positions.known.get(m, anchor or (stamp_s, at))[0]
            reach = self.config.position_gate_m + self.config.max_speed_m_s * (stamp_s - since)
            dist = float(np.linalg.norm(xyz - at))
            ages.append((dist, dist <= reach, m))
        ages.sort()
        if not ages or not ages[0][1]:
            return UNNUMBERED
        bar = ALONE_RATIO * max(ages[0][0], CARRY_FLOOR_M)
        if len(ages) > 1 and ages[1][0] < bar:
            return UNNUMBERED
        return ages[0][2]

    def _grid_point(self, marker: int) -> tuple[float, FloatArray] | None:
        """``(stamp s, (3,) m)``: a marker's fitted grid point in the first camera whose grid
        was fitted, at the grid point's depth, at that fit's stamp; None before any fit."""
        if not self._grid_time:
            return None
        camera = min(self._grid_time, key=lambda c: self._grid_time[c])
        placed = self._grid_xyz(camera, marker)
        return None if placed is None else (self._grid_time[camera], placed[1])

    def _grid_xyz(self, camera: str, marker: int) -> tuple[float, FloatArray] | None:
        """``(depth m, (3,) m)``: the marker's fitted grid point in ``camera`` placed at the
        grid point's depth; None when the camera's grid has no such point."""
        grid_uv = self._grid_uv.get(camera, {})
        if marker not in grid_uv:
            return None
        numbers, xyz = self.config.grid.points()
        cam = self.cameras[camera]
        z = depth(cam, xyz[list(numbers).index(marker)])
        return z, back_project(cam, grid_uv[marker], z)

    def _late_grid(self, camera: str, uv: FloatArray, k: int, seen: set[int]) -> int:
        """A marker this camera never saw, appearing as a new track alone and unambiguously at
        its fitted grid point (it was covered at the start): its number, else -1."""
        grid = self._grid_uv.get(camera, {})
        gate = self.config.grid_gate_px
        free = [m for m in grid if m not in seen and m not in self.latest[camera]]
        near = [m for m in free if np.linalg.norm(uv[k] - grid[m]) < gate]
        if len(near) != 1:
            return UNNUMBERED
        d = np.linalg.norm(uv[k] - grid[near[0]])
        if any(np.linalg.norm(uv[k] - grid[m]) < d + gate / 2 for m in grid if m != near[0]):
            return UNNUMBERED  # another grid point almost as near: unsure
        others = np.delete(uv, k, axis=0)
        if len(others) and (np.linalg.norm(others - grid[near[0]], axis=1) < gate).any():
            return UNNUMBERED  # two spots at one grid point: say nothing
        return near[0]

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

    def _grid_anchor(self, camera: str, marker: int, stamp_s: float,
                     ) -> tuple[FloatArray, float] | None:
        """Where a marker never triangulated can be: ``(point (3,) m, allowed distance m)``.

        Its fitted grid point in ``camera`` (the projected grid shifted onto the detections)
        placed at the grid point's depth, with the grid gate at that depth as extra allowance
        besides the usual ``position_gate_m + max_speed_m_s * dt``; only within
        ``MAX_DEPTH_AGE_S`` of the frame the grid was fitted on, and only for a marker this
        camera has not seen (its own sightings would be the better anchor, but they carry no
        depth). None otherwise.
        """
        t0 = self._grid_time.get(camera)
        if t0 is None or stamp_s - t0 > MAX_DEPTH_AGE_S or marker in self.latest[camera]:
            return None
        placed = self._grid_xyz(camera, marker)
        if placed is None:
            return None
        z, point = placed
        allowed = (self.config.position_gate_m
                   + self.config.grid_gate_px * z / float(self.cameras[camera].K[0, 0])
                   + self.config.max_speed_m_s * (stamp_s - t0))
        return point, allowed

    def _alone(self, camera: str, track_id: int, marker: int, uv: FloatArray,
               markers: NDArray[np.int32], stamp_s: float) -> bool:
        """Whether no other marker can plausibly be at a re-attached spot (one camera's check).

        The track's own marker needs the speed (in this camera) from its last sighting before
        its latest re-attachment to the spot over the time since; every other marker not
        numbered on another spot of this frame (a rival) would need the speed from its own
        last sighting in this camera (never seen here: its fitted grid point when the grid was
        fitted) over its own time since. The spot is the track's marker when each rival would
        need at least ``ALONE_RATIO`` times the own speed (at least ``MIN_SPEED_PX_S``), or
        when the other camera sees the rival now off this spot's epipolar line (more than
        ``3 * epipolar_px``). A marker this camera has no position for at all is a rival
        anywhere (the spot stays withheld).
        Speeds rather than distances: a rival unseen for longer may have moved farther.
        """
        track = next(t for t in self.trackers[camera].tracks if t.track_id == track_id)
        gaps = [i for i in range(len(track.history) - 1)
                if track.history[i + 1][0] - track.history[i][0] > 1.5 / self.config.fps]
        if not gaps:
            return False
        own = track.history[gaps[-1]]  # its last sighting before the latest re-attachment
        own_speed = float(np.hypot(uv[0] - own[1], uv[1] - own[2])) / max(stamp_s - own[0],
                                                                          1e-3)
        taken = {int(m) for m in markers if m >= 0}
        other = self.other(camera)
        for m in self.config.grid.points()[0].tolist():
            if m == marker or m in taken:
                continue
            seen = self.latest[camera].get(m)
            if seen is None and m in self._grid_uv.get(camera, {}):
                seen = (self._grid_time[camera], self._grid_uv[camera][m])
            if seen is None:
                return False  # a marker with nothing to place it: could be anywhere
            speed = float(np.linalg.norm(uv - seen[1])) / max(stamp_s - seen[0], 1e-3)
            if speed > ALONE_RATIO * max(own_speed, MIN_SPEED_PX_S):
                continue
            now = self.latest[other].get(m)
            if now is not None and abs(now[0] - stamp_s) <= RECENT_S and epipolar_distance(
                    self.cameras[camera], self.cameras[other], uv[None], now[1][None]
                    )[0, 0] > 3 * self.config.epipolar_px:
                continue
            return False
        return True

    def _retire(self, camera: str, number: int) -> None:
        """Drop the lost track that held ``number`` (its marker came back as a new track)."""
        tracker = self.trackers[camera]
        tracker.tracks = [t for t in tracker.tracks if not (t.lost and t.marker == number)]

    def _verify(self, camera: str, track_ids: NDArray[np.int64], markers: NDArray[np.int32],
                uv: FloatArray, stamp_s: float, events: list[str]) -> NDArray[np.int32]:
        """Check every numbered point against the other camera's point of the same number.

        A pair farther than ``3 * epipolar_px`` from the epipolar line, or whose 3D point the
        marker cannot have reached since its last accepted position, is withheld (-1) in this
        frame. The track loses that number for good if it was numbered after the start
        (epipolar line, late grid) or if one of its links since its last passed check landed
        more than ``doubt_link_px`` from the prediction (the 2D linker likely took a neighbour
        for the covered marker); otherwise the other camera is the likelier culprit and the
        point is only withheld. Pairs that pass update the marker's 3D position. (Undoing just
        the bad link instead, the track lost again with its number, was tried: on the bundled
        render it let that number re-attach to a neighbour later, 6 switches.)

        A track re-attached since its last passed check more than ``doubt_link_px`` from where
        it was expected is not given out with its number until the other camera confirms it
        (withheld, counted as ``unconfirmed``): a marker that reappears some way off may be a
        neighbour, and a wrong number is worse than none, unless no other marker this camera
        does not see now could be there at a plausible speed (``_alone``, counted as
        ``confirmed_alone``). (Withholding it only when another marker was last seen near the
        spot, at any time, was tried: on the bundled render the switch it should stop, a
        side-camera re-attachment 25 px off after 0.2 s, stayed.)
        """
        other, markers = self.other(camera), markers.copy()
        tracks = {t.track_id: t for t in self.trackers[camera].tracks}
        unsure = {k for k in np.flatnonzero(markers >= 0).tolist()
                  if int(track_ids[k]) in tracks
                  and tracks[int(track_ids[k])].reattach_px > self.config.doubt_link_px}
        partner = self._partners(other, markers, unsure, stamp_s)
        idx = sorted(partner)
        for k in sorted(unsure - set(idx)):
            tid = int(track_ids[k])
            if self._alone(camera, tid, int(markers[k]), uv[k], markers, stamp_s):
                tracks[tid].reattach_px = 0.0
                self.counts[camera].confirmed_alone += 1
                events.append(f'{camera}: marker {markers[k]} re-attached off its prediction '
                              f'kept at {stamp_s:.3f} s: no other marker can be that near')
                continue
            self.counts[camera].unconfirmed += 1
            self._pending[camera][int(markers[k])] = (stamp_s, uv[k])
            events.append(f'{camera}: marker {markers[k]} withheld at {stamp_s:.3f} s: '
                          f're-attached {tracks[int(track_ids[k])].reattach_px:.1f} px from '
                          'its prediction, not yet confirmed by the other camera')
            markers[k] = UNNUMBERED
        xyz, epi = triangulate_pairs(self.cameras[camera], self.cameras[other],
                                     uv[idx], np.array([partner[k] for k in idx]))
        for k, x, d in zip(idx, xyz, epi, strict=True):
            m = int(markers[k])
            dist, allowed = self.positions.distance(m, stamp_s, x)
            # a doubtful re-attachment is confirmed only by the test that numbers a new track
            epi_ok = self.config.epipolar_px if k in unsure else 3 * self.config.epipolar_px
            if d <= epi_ok and dist <= allowed:
                self.positions.accept(m, stamp_s, x)
                self._pending[camera].pop(m, None)
                if int(track_ids[k]) in tracks:
                    tracks[int(track_ids[k])].link_px = 0.0
                    tracks[int(track_ids[k])].reattach_px = 0.0
                continue
            counts = self.counts[camera]
            counts.withheld += 1
            if d > epi_ok:
                counts.epipolar_conflicts += 1
                why = f'{d:.1f} px off the epipolar line'
            else:
                counts.position_conflicts += 1
                why = f'3D point {1e3 * dist:.0f} mm from its last position (at most ' \
                      f'{1e3 * allowed:.0f} mm)'
            markers[k] = UNNUMBERED
            tid = int(track_ids[k])
            jump = tracks[tid].link_px if tid in tracks else 0.0
            if tid in self._late_numbered[camera] or jump > self.config.doubt_link_px:
                self._late_numbered[camera].discard(tid)
                self._refused[camera].add((tid, m))
                self.trackers[camera].number(tid, UNNUMBERED)
                counts.revoked += 1
                why += '; its number taken back'
            msg = f'{camera}: marker {m} withheld at {stamp_s:.3f} s: {why}'
            events.append(msg)
            LOG.warning(msg)
        return markers

    def _partners(self, other: str, markers: NDArray[np.int32], unsure: set[int],
                  stamp_s: float) -> dict[int, FloatArray]:
        """The other camera's point (2,) px of each numbered detection's marker, seen within a
        frame period: its given-out point, or for an unsure re-attachment (index in ``unsure``)
        also its withheld, unconfirmed one (two cameras that both lost a marker re-attach it
        with no given-out point to check against; the pair can confirm both)."""
        out: dict[int, FloatArray] = {}
        for k in np.flatnonzero(markers >= 0).tolist():
            m = int(markers[k])
            sources = (self.latest[other], self._pending[other]) if k in unsure \
                else (self.latest[other],)
            for source in sources:
                hit = source.get(m)
                if hit is not None and abs(hit[0] - stamp_s) <= 1.0 / self.config.fps:
                    out[k] = hit[1]
                    break
        return out

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
