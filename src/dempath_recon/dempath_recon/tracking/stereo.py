"""Markers from two cameras' images: detect, track, number, check, triangulate (stream, batch).

:class:`StereoMarkerTracker` takes the frames of both cameras one at a time in arrival order
(``update(camera, stamp, jpeg)``): it decodes and detects (``detect``), links to the camera's
tracks (``linker``), numbers a camera's tracks by the marker grid once a frame fits it, and
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
``release``, ``flush``), and :func:`~dempath_recon.tracking.trajectories.triangulate_tracks`
(re-exported here) turns the numbered pixel tracks into 3D trajectories.

The tracker's parts live beside it in this room: its state, one record (``state``), the
numbering of a camera's tracks by the grid and the epipolar lines (``numbering``), the checks on
one camera's evidence (``one_camera``), the pair checks before anything is given out
(``pair_checks``), the numbering of a marker back in both cameras as a pair
(``pair_numbering``), the numbering of a track left unnumbered by a track of the other camera
that held on its epipolar line over several frames (``track_pairs``), the publication delay
(``release``) and the records (``records``).
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import forget_pixels, marker_diameter_px, view_of_up
from dempath_recon.tracking.bed_numbering import number_by_bed
from dempath_recon.tracking.carried_numbers import withhold_carried
from dempath_recon.tracking.coming_out import number_coming_out
from dempath_recon.tracking.crowded_pair import give_back
from dempath_recon.tracking.detect import (
    Detections,
    ImageDecodeError,
    MarkerDetector,
    decode_jpeg,
    own_detections,
)
from dempath_recon.tracking.grid_elimination import (
    number_by_elimination,
    revoke_jumped,
    revoke_shared,
)
from dempath_recon.tracking.joint_fill import fill_jointly
from dempath_recon.tracking.link_guide import ambiguous_spots, barred_links
from dempath_recon.tracking.linker import UNNUMBERED
from dempath_recon.tracking.merge import StampMerge
from dempath_recon.tracking.merge_release import (
    keep_released_free,
    merged_spots,
    release_merged,
    spot_sizes,
)
from dempath_recon.tracking.numbering import (
    number_all_by_grid,
    number_grid_unsure,
    number_new,
)
from dempath_recon.tracking.pair_checks import verify
from dempath_recon.tracking.pair_numbering import number_pairs
from dempath_recon.tracking.parted import flagged, revoke_at_parting
from dempath_recon.tracking.pass_audit import audit_pass
from dempath_recon.tracking.path_smoother import smooth_paths
from dempath_recon.tracking.piece_numbering import number_pieces
from dempath_recon.tracking.publish_gate import PublicationGate
from dempath_recon.tracking.ray_rivals import keep_candidates, resolve_waiting
from dempath_recon.tracking.records import CameraCounts, PixelFrame, StereoTrackConfig
from dempath_recon.tracking.regain import number_regained
from dempath_recon.tracking.release import HeldFrame, fill_confirmed, renumber
from dempath_recon.tracking.shake import ShakeEstimate, ShakeEstimator, remove_shake
from dempath_recon.tracking.split import EAGER_GAIN, GAIN
from dempath_recon.tracking.state import (
    Sighting,
    StereoState,
    forget_refusals,
    report,
    unnumbered_tracks,
)
from dempath_recon.tracking.touching_exchange import withhold_exchanged
from dempath_recon.tracking.track_pairs import number_by_track_pairs
from dempath_recon.tracking.track_split import split_by_tracks
from dempath_recon.tracking.trajectories import marker_histories, triangulate_tracks
from dempath_recon.tracking.whole_pass import number_whole_pass

__all__ = ['CameraCounts', 'PixelFrame', 'StereoMarkerTracker', 'StereoTrackConfig',
           'camera_detectors', 'marker_histories', 'track_bag', 'triangulate_tracks']
LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]

VIEW_MOVED_PX = 1.0  # a pass whose mean image position is this far off the calibration's
# view is said to have moved [px] (the shake's own estimate: a few hundredths of a pixel)
BLIND_FRAMES = 10  # frames of a camera without any marker before it is said once (0.2 s at 50 FPS)


class StereoMarkerTracker:
    """Streaming two-camera marker pipeline: a detector and the state record
    (:class:`~dempath_recon.tracking.state.StereoState`), run frame by frame through the
    numbering and the checks.

    Args:
        cameras: ``{name: camera}`` for the two cameras (calibrated, world frame).
        config: pipeline settings.
    """

    def __init__(self, cameras: dict[str, Camera], config: StereoTrackConfig | None = None,
                 ) -> None:
        self.state = StereoState.start(cameras, config or StereoTrackConfig())
        forget_pixels()  # the undistortion memo serves this tracker's frames (not a past run's)
        self.detectors = camera_detectors(cameras, self.state.config)
        self.shakers = {c: ShakeEstimator(self.state.config.shake_align) for c in cameras} \
            if self.state.config.shake \
            else {}
        self.gate = PublicationGate(cameras, self.state.config.fps) \
            if self.state.config.publish_gate else None
        # the tracks linked to a crowded spot (two markers) in each camera's last frame
        self._crowded: dict[str, set[int]] = {c: set() for c in cameras}
        # each camera's frames' shifts against its first frame, by stamp (for release): the
        # latest ones, or with config.whole_pass every frame of the pass (re-placed at flush)
        self._relative: dict[str, dict[float, FloatArray]] = {c: {} for c in self.shakers}
        # with config.whole_pass: the frames due so far, numbered as due, kept till flush
        self._pass: list[tuple[HeldFrame, PixelFrame]] = []
        # (camera, stamp) -> (k, 2) how far the flux's seen share moves each point of the
        # frame (``config.flux_share``), applied after the whole pass's numbering [px]
        self._flux_shift: dict[tuple[str, float], FloatArray] = {}
        # the whole pass's frames with those centres (smoothed as the published ones), given
        # out in their place with the numbers the publication gate left on the mass's centres
        self._moved: list[PixelFrame] | None = None

    @property
    def cameras(self) -> dict[str, Camera]:
        """``{name: camera}`` of the two cameras."""
        return self.state.cameras

    @property
    def config(self) -> StereoTrackConfig:
        """The pipeline's settings."""
        return self.state.config

    @property
    def counts(self) -> dict[str, CameraCounts]:
        """What happened to each camera's frames so far."""
        return self.state.counts

    def other(self, camera: str) -> str:
        """The other camera's name."""
        return self.state.other(camera)

    def held(self) -> int:
        """Frames held for the publication delay (``release``/``flush`` give them out)."""
        return len(self.state.queue)

    def report(self) -> dict[str, Any]:
        """Counts per camera, and the stamp gaps where frames were missing."""
        return report(self.state)

    def note_other(self, camera: str, stamp_s: float, markers: NDArray[np.int32],
                   uv: FloatArray) -> None:
        """Numbered points of ``camera`` that another tracker gave out (a detector node hears
        the other camera's ``pixel_points``): they become that camera's latest sightings, for
        numbering by the epipolar line and the pair checks."""
        latest: dict[int, Sighting] = self.state.latest[camera]
        for m, p in zip(markers, uv, strict=True):
            latest[int(m)] = (stamp_s, np.asarray(p, np.float64))

    def update(self, camera: str, stamp_s: float, jpeg: bytes | NDArray[np.uint8]) -> PixelFrame:
        """One compressed frame of ``camera``; never raises for bad images (counts them)."""
        counts = self.counts[camera]
        detector = self.detectors[camera]
        try:
            image = decode_jpeg(jpeg, detector.config.downscale)
        except ImageDecodeError as err:
            index = counts.frames + counts.undecodable + counts.out_of_order  # of this camera
            counts.undecodable += 1
            msg = (f'{camera} frame {index} at {stamp_s:.6f} s: {err}; skipped (undecodable '
                   f'frames so far: {counts.undecodable})')
            LOG.warning(msg)
            return PixelFrame(camera, stamp_s, np.zeros(0, np.int32), np.zeros((0, 2)),
                              np.zeros(0), (msg,), None, np.zeros(0), np.zeros(0))
        return self.update_detections(camera, stamp_s, detector.detect(image, prescaled=True),
                                      self._shake(camera, stamp_s, image,
                                                  detector.config.downscale))

    def add_reference(self, camera: str, jpeg: bytes | NDArray[np.uint8]) -> None:
        """One of the frames ``camera``'s calibration was made on (before the pass's first
        frame; ``config.shake_reference``): the shake is placed against their view, so that a
        pass seen off the calibration as a whole is corrected too."""
        shaker = self.shakers.get(camera)
        if shaker is None or not self.config.shake_reference:
            return
        try:
            image = decode_jpeg(jpeg, self.detectors[camera].config.downscale)
        except ImageDecodeError as err:
            LOG.warning('%s calibration frame: %s; not used', camera, err)
            return
        try:
            shaker.add_reference(image, self.detectors[camera].config.downscale)
        except ValueError as err:  # the pass has started: its anchor is set
            LOG.warning('%s calibration frame: %s; not used', camera, err)

    def update_image(self, camera: str, stamp_s: float, image: NDArray[np.uint8]) -> PixelFrame:
        """One decoded BGR frame (full size) of ``camera``."""
        return self.update_detections(camera, stamp_s, self.detectors[camera].detect(image),
                                      self._shake(camera, stamp_s, image, 1))

    def _shake(self, camera: str, stamp_s: float, image: NDArray[np.uint8],
               full_per_px: float) -> ShakeEstimate | None:
        """The frame's image motion (None when the correction is off)."""
        shaker, last = self.shakers.get(camera), self.state.last_stamp[camera]
        if shaker is None or (last is not None and stamp_s <= last):  # off, or skipped
            return None
        shake = shaker.update(image, full_per_px)
        offset = shaker.view_offset_px
        if offset is not None:
            note_view_offset(self.counts[camera], camera, offset)
        return shake

    def update_detections(self, camera: str, stamp_s: float, det: Detections,
                          shake: ShakeEstimate | None = None) -> PixelFrame:
        """One frame's detections of ``camera``: link, number, check against the other camera.

        With ``shake`` (the frame's image motion, :mod:`~dempath_recon.tracking.shake`), the
        detections are first moved back into the calibration's view.

        The returned frame's markers are -1 where a detection is not identified, or where its
        number disagrees with the other camera (off the epipolar line, or a 3D point the
        marker cannot have reached): such a point is withheld, never given out as the marker.
        """
        state = self.state
        counts, tracker = state.counts[camera], state.trackers[camera]
        last = state.last_stamp[camera]
        if last is not None and stamp_s <= last:
            counts.out_of_order += 1
            msg = f'{camera} frame at {stamp_s:.6f} s is not after {last:.6f} s; skipped'
            LOG.warning(msg)
            return PixelFrame(camera, stamp_s, np.zeros(0, np.int32), np.zeros((0, 2)),
                              np.zeros(0), (msg,), None, np.zeros(0), np.zeros(0))
        events: list[str] = []
        if last is not None and stamp_s - last > 1.5 / state.config.fps:
            missed = round((stamp_s - last) * state.config.fps) - 1
            counts.dropped += max(missed, 1)
            counts.gaps_s.append((last, stamp_s))
            events.append(f'{camera}: {max(missed, 1)} frame(s) missing before {stamp_s:.3f} s')
        state.last_stamp[camera] = stamp_s
        counts.frames += 1
        shake_px = note_shake(counts, camera, stamp_s, shake, events)
        if shake_px is not None and shake is not None:
            det = remove_shake(det, shake_px)
            self._keep_relative(camera, stamp_s, shake.relative_px)
        counts.no_marker += int(len(det.uv) == 0)
        if counts.frames == BLIND_FRAMES and counts.no_marker == counts.frames:
            det_cfg = self.detectors[camera].config
            msg = (f'{camera}: no marker found in the first {BLIND_FRAMES} frames: the detector '
                   f'looks for {det_cfg.colour_name()} above {det_cfg.threshold:g}); markers of '
                   'another colour (set marker_bgr), an image far too dark, or a camera that '
                   'does not see the grid give nothing')
            LOG.warning(msg)
            events.append(msg)
        own_bars: dict[int, NDArray[np.bool_]] = {}
        if state.config.track_split:
            det, own_bars = self._split_by_tracks(camera, stamp_s, det, shake_px, events)
        barred = join_bars(barred_links(state, camera, det.uv, stamp_s), own_bars)
        before = (tracker.counts.lost, tracker.counts.reattached)
        tf = tracker.update(stamp_s, det, barred)
        record = state.record
        if record is not None:
            record.reattached(camera, stamp_s, tracker.tracks)

        def step(rule: str) -> None:  # the next numbering rule starts (for the record)
            if record is not None:
                record.begin(rule, camera, stamp_s, events)

        counts.detected += len(det.uv)
        counts.lost += tracker.counts.lost - before[0]
        counts.reattached += tracker.counts.reattached - before[1]
        forget_refusals(state, camera, stamp_s)
        step('parted')
        markers = revoke_at_parting(state, camera, tf.track_ids, tf.markers, tf.uv, det,
                                    self._crowded[camera], stamp_s,
                                    self.detectors[camera].config.marker_diameter_px, events)
        self._crowded[camera] = {int(t) for t in tf.track_ids[flagged(det, det.crowded, tf.uv)]}
        if state.config.merge_release:
            step('merge_release')
            keep_released_free(state, camera, stamp_s)
            merged = merged_spots(state, camera, tf.track_ids, tf.uv,
                                  spot_sizes(tf.uv, det.uv, det.size_px), stamp_s,
                                  self.detectors[camera].config.marker_diameter_px)
            markers = release_merged(state, camera, tf.track_ids, markers, merged, stamp_s,
                                     events)
        step('grid_fit')
        if camera not in state.grid_uv:
            markers = number_all_by_grid(state, camera, tf.track_ids, tf.uv, stamp_s, events)
        step('number_new')
        markers = number_new(state, camera, tf.track_ids, markers, tf.uv, stamp_s, events)
        step('grid_unsure')
        markers = number_grid_unsure(state, camera, tf.track_ids, markers, tf.uv, stamp_s,
                                     events)
        if state.config.ray_rivals:
            step('ray_rivals')
            markers = resolve_waiting(state, camera, tf.track_ids, markers, tf.uv, stamp_s,
                                      events)
        step('pair_numbering')
        markers = number_pairs(state, camera, tf.track_ids, markers, tf.uv, stamp_s, events)
        step('track_pairs')
        markers = number_by_track_pairs(state, camera, tf.track_ids, markers, tf.uv, stamp_s,
                                        events)
        if state.config.elimination:
            step('elimination_jumped')
            markers = revoke_jumped(state, camera, tf.track_ids, markers, events)
            step('elimination')
            markers = number_by_elimination(state, camera, tf.track_ids, markers, tf.uv,
                                            stamp_s, events)
            if state.config.regain:
                step('regain')
                markers = number_regained(state, camera, tf.track_ids, markers, stamp_s,
                                          events)
        if state.config.coming_out:
            step('coming_out')
            markers = number_coming_out(state, camera, tf.track_ids, markers, tf.uv, stamp_s,
                                        events)
        if state.config.crowded_pairs and state.config.crowd_give_back:
            step('crowd_give_back')
            markers = give_back(state, camera, tf.track_ids, markers, tf.uv, stamp_s, events)
        if state.config.ray_rivals:
            step('ray_rivals')
            markers = keep_candidates(state, camera, tf.track_ids, markers, events)
        step('pair_checks')
        markers = verify(state, camera, tf.track_ids, markers, tf.uv, stamp_s, events)
        waiting = waiting_points(state, camera, markers, tf.uv, stamp_s)
        markers = withhold_crowded(det, tf.uv, markers)
        merged = ambiguous_spots(tracker, tf._replace(markers=markers),
                                 self.detectors[camera].config.marker_diameter_px)
        if merged.any():
            step('merged_spot')
            revoke_shared(state, camera, tf.track_ids, merged, events)
            counts.merged += int(merged.sum())
            events += [f'{camera}: marker {m} withheld at {stamp_s:.3f} s: its spot may hold '
                       'a neighbour lost beside it' for m in markers[merged].tolist()]
            markers = np.where(merged, UNNUMBERED, markers).astype(np.int32)
        free_mask = unnumbered_tracks(state, camera, tf.track_ids, markers)
        free = np.flatnonzero(free_mask)
        state.free[camera] = (stamp_s, tf.track_ids[free], tf.uv[free])
        state.last_tracks[camera] = (stamp_s, tf.track_ids, tf.uv)
        counts.tracked += int((markers >= 0).sum())
        for m, p in zip(markers, tf.uv, strict=True):
            if m >= 0:
                state.latest[camera][int(m)] = (stamp_s, p)
        if record is not None:
            record.frame_done(camera, stamp_s, tf.track_ids, markers)
        size_px, mass = spot_measures(det, tf.uv)
        published = published_centres(det, tf.uv)
        if self.config.flux_share and self.config.whole_pass:
            moved = flux_moved(det, tf.uv)
            if moved is not None:
                self._flux_shift[(camera, stamp_s)] = moved - published
        frame = PixelFrame(camera, stamp_s, markers, published,
                           tf.confidence, tuple(events) + tf.events, shake_px, size_px, mass)
        state.queue.hold(frame, tf.track_ids, free_mask, waiting)
        return frame

    def _split_by_tracks(self, camera: str, stamp_s: float, det: Detections,
                         shake_px: FloatArray | None, events: list[str],
                         ) -> tuple[Detections, dict[int, NDArray[np.bool_]]]:
        """The frame's detections with spots its numbered tracks say hold two markers split
        (:mod:`~dempath_recon.tracking.track_split`), and the parts each track may not take."""
        detector = self.detectors[camera]
        cfg = detector.config
        return split_by_tracks(self.state, camera, det, stamp_s, detector.marker_size(det.size_px),
                               cfg.downscale, cfg.threshold, detector.cut_up, shake_px, events)

    def release(self) -> list[PixelFrame]:
        """The frames now ``number_delay_frames`` frames old in their camera, in arrival
        order (with a delay of 0: the frame ``update`` just returned). Call it after every
        ``update``: frames older than the delay are dropped at the next ``update`` (a caller
        that only uses ``update``'s frames, like the detector node, holds nothing).

        A point that was unnumbered on arrival because its track had no number goes out with
        the number the track has now, if the track was given one since and kept its 2D links
        in the meantime (no re-attachment after that frame, which could be another marker)
        and no other point of the frame has that number. Held frames keep their stamps: the
        delay only postpones them. With ``config.whole_pass`` the frames are numbered so and
        kept till ``flush`` (nothing is given out before the pass ends).
        """
        due = [(h, self._anchored(h)) for h in self.state.queue.due()]
        if self.config.whole_pass:
            self._pass += due
            return []
        return [self._gated(h, f) for h, f in due]

    def flush(self) -> list[PixelFrame]:
        """All frames still held (end of a recording), with the numbers known now; with
        ``config.whole_pass``, every frame of the pass, the tracks still never numbered then
        numbered from all of them at once (:mod:`~dempath_recon.tracking.whole_pass`)."""
        held = self._pass + [(h, self._anchored(h)) for h in self.state.queue.rest()]
        self._pass = []
        frames = [f for _, f in held]
        if self.config.whole_pass and held:
            # the calibration's view placed by the mean shift of the whole pass, not of the
            # frames till each was due (shake_3px: 3D RMS 2.89 -> 2.24 mm)
            frames = self._whole_pass([h for h, _ in held], [self._reanchor(f) for f in frames])
        out = [self._gated(h, f) for (h, _), f in zip(held, frames, strict=True)]
        moved, self._moved = self._moved, None
        if moved is None:
            return out
        # the flux's centres go out with the numbers and withholdings decided on the mass's
        return [m._replace(markers=f.markers, events=f.events)
                for f, m in zip(out, moved, strict=True)]

    def _whole_pass(self, held: list[HeldFrame], frames: list[PixelFrame]) -> list[PixelFrame]:
        """``frames`` numbered from the whole pass, the points it numbered counted."""
        state = self.state
        track_ids = [h.track_ids for h in held]
        sizes = self._diameters()
        out, _ = number_whole_pass(frames, track_ids, self.cameras,
                                   state.grid_uv, state.config.epipolar_px, state.config.fps)
        self._count_renumbered(frames, out, 'numbered_whole_pass')
        if state.config.piece_numbering:
            pieces, _ = number_pieces(out, track_ids, self.cameras, state.grid_uv, sizes,
                                      state.config.epipolar_px, state.config.fps)
            out = self._count_renumbered(out, pieces, 'numbered_pieces')
        late = state.config.bed_after_fill
        if state.config.bed_numbering and not late:
            out = self._by_bed(out, track_ids, sizes)
        if state.config.joint_fill:
            filled, _ = fill_jointly(out, track_ids, self.cameras,
                                     state.config.epipolar_px, state.config.fps)
            out = self._count_renumbered(out, filled, 'numbered_joint_fill')
        if state.config.bed_numbering and late:
            out = self._by_bed(out, track_ids, sizes)
        if state.config.pass_audit:
            audit = audit_pass(out, track_ids, self.cameras, sizes,
                               state.config.fps, renumber=state.config.audit_renumber)
            out = audit.frames
            for cam, n in audit.renumbered.items():
                state.counts[cam].audit_renumbered += n
                state.counts[cam].audit_withheld += audit.withheld[cam]
        if state.config.carried_confirm:  # numbers carried over a break checked
            carried = withhold_carried(out, track_ids, self.cameras, sizes,
                                       state.config.fps)
            out = carried.frames
            for cam, n in carried.withheld.items():
                state.counts[cam].carried_withheld += n
        if state.config.touch_confirm:  # then those of touching markers
            touched = withhold_exchanged(out, track_ids, self.cameras, sizes,
                                         state.config.fps, wait=state.config.touch_wait,
                                         swap=state.config.touch_swap)
            out = touched.frames
            for cam, n in touched.withheld.items():
                state.counts[cam].touch_withheld += n
                state.counts[cam].touch_swapped += touched.swapped[cam]
        shifts, self._flux_shift = self._flux_shift, {}
        if state.config.shake_shrink:
            shifts = self._shrunk_shake(out, shifts)
        moved = None if not shifts else [  # the flux's centres, once every number is given
            f._replace(uv=f.uv + shift) if (shift := shifts.get((f.camera, f.stamp_s)))
            is not None and shift.shape == f.uv.shape else f for f in out]
        if state.config.smooth_paths:
            out = smooth_paths(out, state.config.fps)
            moved = None if moved is None else smooth_paths(moved, state.config.fps)
        self._moved = moved
        return out

    def _by_bed(self, out: list[PixelFrame], track_ids: list[NDArray[np.int64]],
                sizes: dict[str, float]) -> list[PixelFrame]:
        """``out`` with unnumbered pieces numbered by the bed's motion
        (:func:`~dempath_recon.tracking.bed_numbering.number_by_bed`), counted."""
        state = self.state
        ids, xyz = state.config.grid.points()
        bed, _ = number_by_bed(out, track_ids, self.cameras, state.grid_uv,
                               dict(zip(ids.tolist(), xyz, strict=True)), sizes,
                               state.config.epipolar_px, state.config.fps,
                               sheared=state.config.bed_sheared)
        return self._count_renumbered(out, bed, 'numbered_by_bed')

    def _shrunk_shake(self, frames: list[PixelFrame],
                      shifts: dict[tuple[str, float], FloatArray],
                      ) -> dict[tuple[str, float], FloatArray]:
        """``shifts`` (each frame's points' moves after the numbering, :meth:`_whole_pass`)
        with each frame's shake scaled about the pass's mean by the share that is not the
        estimate's noise (``config.shake_shrink``, :meth:`ShakeEstimator.placed`): the
        numbers, decided on the shake as estimated, stay."""
        out = dict(shifts)
        for f in frames:
            shaker, rel = self.shakers.get(f.camera), self._relative.get(f.camera, {})
            if shaker is None or f.shake_px is None or f.stamp_s not in rel:
                continue
            r = rel[f.stamp_s]
            step = shaker.placed(r, shrink=False) - shaker.placed(r, shrink=True)
            key = (f.camera, f.stamp_s)
            known = out.get(key)
            out[key] = (known if known is not None and known.shape == f.uv.shape
                        else np.zeros_like(f.uv)) + step
        return out

    def _count_renumbered(self, before: list[PixelFrame], after: list[PixelFrame],
                          counter: str) -> list[PixelFrame]:
        """``after``, with the points whose number a whole-pass step changed from ``before``
        added to each camera's ``counter`` (a :class:`CameraCounts` field)."""
        for old, new in zip(before, after, strict=True):
            counts = self.state.counts[new.camera]
            setattr(counts, counter,
                    getattr(counts, counter) + int((new.markers != old.markers).sum()))
        return after

    def _diameters(self) -> dict[str, float]:
        """Camera -> a marker's diameter in its images [px] (its detector's)."""
        return {c: d.config.marker_diameter_px for c, d in self.detectors.items()}

    def _anchored(self, held: HeldFrame) -> PixelFrame:
        """A held frame due to go out, with the numbers its tracks got since (``renumber``,
        ``fill_confirmed``), re-anchored (:meth:`_reanchor`)."""
        state = self.state
        tracks = {t.track_id: t for t in state.trackers[held.camera].tracks}  # by id, for both
        frame, late = renumber(held, tracks, state.config.fps)
        frame, filled = fill_confirmed(held, frame, tracks, state.confirmed[held.camera],
                                       state.config.fps)
        state.counts[held.camera].numbered_late += late
        state.counts[held.camera].confirmed_late += filled
        return self._reanchor(frame)

    def _gated(self, held: HeldFrame, frame: PixelFrame) -> PixelFrame:
        """A frame going out, through the publication gate."""
        state = self.state
        if self.gate is None:
            return frame
        frame, gated = self.gate.check(frame)
        if gated:
            state.counts[held.camera].gated += len(gated)
            frame = frame._replace(events=frame.events + tuple(
                f'{held.camera}: marker {m} withheld at {frame.stamp_s:.3f} s: its pair does '
                'not fit (its 3D point jumped unlike its neighbours, or reprojects far off)'
                for m in gated))
        return frame

    def _keep_relative(self, camera: str, stamp_s: float, relative_px: FloatArray) -> None:
        """Keep a frame's shift against its camera's first frame till it goes out: the
        latest ``number_delay_frames + 2`` frames', or every frame's with ``whole_pass``."""
        kept = self._relative[camera]
        kept[stamp_s] = relative_px
        if not self.config.whole_pass and len(kept) > self.config.number_delay_frames + 2:
            del kept[next(iter(kept))]  # the oldest (dicts keep their insertion order)

    def _reanchor(self, frame: PixelFrame) -> PixelFrame:
        """A frame given out later, its shake taken off against the calibration's view as
        known now: the mean of more frames (the frames since it was numbered; with
        ``whole_pass``, at ``flush``, every frame of the pass) places that view better. Only
        a common offset of the frame's points changes, never a number."""
        rel = self._relative.get(frame.camera, {}).get(frame.stamp_s)
        if rel is None or frame.shake_px is None:
            return frame
        now = self.shakers[frame.camera].placed(rel, shrink=False)
        return frame._replace(uv=frame.uv + frame.shake_px - now, shake_px=now)


def join_bars(a: dict[int, NDArray[np.bool_]], b: dict[int, NDArray[np.bool_]],
              ) -> dict[int, NDArray[np.bool_]]:
    """Track id -> (n,) the detections a track may not take by either of ``a`` and ``b``."""
    if not b:
        return a
    out = dict(a)
    for tid, bar in b.items():
        out[tid] = bar | out[tid] if tid in out else bar
    return out


def note_view_offset(counts: CameraCounts, camera: str, offset_px: FloatArray) -> None:
    """Keep the pass's mean image position against the calibration's view (a camera moved
    since it was calibrated), and say it once when it passes ``VIEW_MOVED_PX``."""
    size = float(np.linalg.norm(offset_px))
    if size > VIEW_MOVED_PX and counts.view_offset_px <= VIEW_MOVED_PX:
        LOG.warning('%s: the image sits (%.1f, %.1f) px off the view the calibration was made '
                    'on (the pass so far): the camera moved since; its points are corrected',
                    camera, offset_px[0], offset_px[1])
    counts.view_offset_px = size


def note_shake(counts: CameraCounts, camera: str, stamp_s: float, shake: ShakeEstimate | None,
               events: list[str]) -> FloatArray | None:
    """Count a frame's image motion; the shift to take off its detections (None: none)."""
    if shake is None:
        return None
    if not shake.known:
        counts.shake_unknown += 1
        events.append(f'{camera}: image motion at {stamp_s:.3f} s not estimated ('
                      f'{shake.agreeing} of {shake.tiles} tiles agree); not corrected')
        return None
    size = float(np.linalg.norm(shake.shift_px))
    counts.shake_frames += int(size > 0.5)
    counts.shake_max_px = max(counts.shake_max_px, size)
    return shake.shift_px


def waiting_points(state: StereoState, camera: str, markers: NDArray[np.int32], uv: FloatArray,
                   stamp_s: float) -> NDArray[np.int32]:
    """(k,) the number each point of this frame was withheld from while its track waits for
    the other camera (``state.pending`` holds it at this stamp and spot), -1 for the rest."""
    out = np.full(len(markers), UNNUMBERED, np.int32)
    for m, (t, p) in state.pending[camera].items():
        if t != stamp_s:
            continue
        hit = np.flatnonzero((markers < 0) & np.all(uv == p, axis=1))
        if len(hit):
            out[hit[0]] = m
    return out


def spot_measures(det: Detections, uv: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(k,) the size (radius of gyration [px]) and (k,) the mass (integrated likelihood,
    ``Detections.mass``; NaN where the detector did not measure it) of the detection each
    tracked point ``uv`` (k, 2) px took; NaN for a point on no detection (a faint spot)."""
    own = own_detections(det.uv, uv) if len(det.uv) else np.full(len(uv), -1, np.intp)
    hit = own >= 0
    at = np.maximum(own, 0)
    size = np.where(hit, np.asarray(det.size_px, np.float64)[at], np.nan) if len(det.uv) \
        else np.full(len(uv), np.nan)
    mass = np.where(hit, np.asarray(det.mass, np.float64)[at], np.nan) \
        if len(det.uv) and det.mass is not None else np.full(len(uv), np.nan)
    return size, mass


def published_centres(det: Detections, uv: FloatArray) -> FloatArray:
    """(k, 2) the points a frame gives out: each tracked point ``uv`` (k, 2) that is one of the
    frame's detections takes that detection's marker centre (``Detections.centre``: a partly
    covered marker's disc centre); others (faint spots) stay as tracked. Only what is published
    moves: the links, numbers and pair checks keep the measured centroids."""
    if det.centre is None or not len(uv) or not len(det.uv):
        return uv
    index = {tuple(p): i for i, p in enumerate(det.uv.tolist())}
    out = np.asarray(uv, np.float64).copy()
    for k, p in enumerate(uv.tolist()):
        i = index.get(tuple(p))
        if i is not None:
            out[k] = det.centre[i]
    return out


def flux_moved(det: Detections, uv: FloatArray) -> FloatArray | None:
    """(k, 2) the points a frame gives out (``published_centres``) with each partly covered
    marker's centre placed by the seen share its chroma flux gives (``Detections.flux_shift``,
    :mod:`~dempath_recon.tracking.seen_flux`), or None where the detections carry no such
    shift for each of their spots (off, or spots split again by the tracks).

    Why apart from ``centre``: the whole pass's numbering and the publication gate decide on
    the published points, and their margins were tuned on the centroid mass's centres; a
    change of centres flips some of their decisions (on 14 tuning looks: one look gained a
    wrong pair, another lost one; with the numbering kept, the gate let one more switch out),
    so the flux's centres take the place of those only after every number and withholding is
    decided (``flush``)."""
    shift = det.flux_shift
    if shift is None or det.centre is None or len(shift) != len(det.uv):
        return None
    return published_centres(det._replace(centre=det.centre + shift), uv)


def withhold_crowded(det: Detections, uv: FloatArray, markers: NDArray[np.int32],
                     ) -> NDArray[np.int32]:
    """``markers`` with the points of crowded spots (``Detections.crowded``: two touching
    markers left in one spot, its centre between them) unnumbered; the track keeps its
    number. ``uv`` (k, 2) are the frame's points, each one of ``det``'s."""
    if det.crowded is None or not det.crowded.any():
        return markers
    big = {tuple(p) for p in det.uv[det.crowded].tolist()}
    out = markers.copy()
    out[[tuple(p) in big for p in uv.tolist()]] = UNNUMBERED
    return out


def camera_detectors(cameras: dict[str, Camera], config: StereoTrackConfig,
                     ) -> dict[str, MarkerDetector]:
    """Each camera's detector: ``config.detector`` with the markers' expected diameter in that
    camera's image (``marker_diameter_px`` from the calibration, the grid's depth and
    ``config.marker_diameter_m``, unless the detector's settings give one) and the image
    direction of world up there and the line of sight's elevation (``view_of_up``, for partly
    covered markers' centres, unless ``config.uncover`` is off or the detector's settings give
    an up direction), without the dim pass where ``config.dim_spots`` is off, and with the
    band-pass, the smoothed centres and the flux's seen share as ``config.band_pass``,
    ``config.smooth_centres`` and ``config.flux_share`` say, and the splitting's gain
    ``split.EAGER_GAIN`` where ``config.eager_split`` says so (unless the detector's settings
    give another), and the band-pass adding spots only and the faint search's contrast spots
    where ``config.band_adds_only`` and ``config.contrast_faint`` say so."""
    out = {}
    for name, cam in cameras.items():
        det = config.detector
        if not config.dim_spots:
            det = replace(det, dim_spots=False)
        if (det.band_pass, det.smooth_centres, det.flux_share) != (
                config.band_pass, config.smooth_centres, config.flux_share):
            det = replace(det, band_pass=config.band_pass, smooth_centres=config.smooth_centres,
                          flux_share=config.flux_share)
        if (det.contrast_faint, det.band_adds_only) != (config.contrast_faint,
                                                        config.band_adds_only):
            det = replace(det, contrast_faint=config.contrast_faint,
                          band_adds_only=config.band_adds_only)
        if config.eager_split and det.split_gain == GAIN:
            det = replace(det, split_gain=EAGER_GAIN)
        if det.marker_diameter_px == 0 and config.marker_diameter_m > 0:
            det = replace(det, marker_diameter_px=marker_diameter_px(
                cam, config.grid, config.marker_diameter_m))
        if config.uncover and tuple(det.up_px) == (0.0, 0.0):
            up, elevation = view_of_up(cam, config.grid)
            det = replace(det, up_px=up, view_elevation_deg=elevation)
        out[name] = MarkerDetector(det)
    return out


def track_bag(bag: Path, cameras: dict[str, Camera], config: StereoTrackConfig | None = None,
              start_ns: int = 0) -> tuple[list[PixelFrame], dict[str, Any]]:
    """Batch form over a bag's ``/<cam>/image_raw/compressed`` topics, the two cameras'
    frames merged by stamp (:class:`~dempath_recon.tracking.merge.StampMerge`, as the detector
    node does with ``lossless``), each camera's in bag order.

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
    merge: StampMerge[bytes] = StampMerge(cameras)
    with open_bag(bag, list(topic_cam)) as reader:
        for raw in reader.messages(list(topic_cam)):
            msg = reader.deserialize(raw)
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            if stamp < start_ns:
                continue
            seconds = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9  # as the node
            for cam, stamp_s, data in merge.push(topic_cam[raw.topic], seconds,
                                                 bytes(msg.data)):
                tracker.update(cam, stamp_s, data)
                frames += tracker.release()
    for cam, stamp_s, data in merge.rest():
        tracker.update(cam, stamp_s, data)
        frames += tracker.release()
    return frames + tracker.flush(), tracker.report()
