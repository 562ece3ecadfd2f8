"""The joint 3D tracker run frame by frame: pair the two cameras' frames by stamp, number the
markers by the grid in 3D, then assign every pair of frames jointly and give the frames out.

Frames come one camera at a time in stamp order (``update_detections``); a frame waits until
the other camera's frame of the same instant (within half a frame period: the cameras expose a
few ms apart) arrives, and the two are decided together. A frame whose partner never comes (a
dropped frame, the end of the recording) is decided alone, from its own camera's rays. A
marker's point is given out only when the assignment is unambiguous in that camera and its
spot is not one the detector flags as two touching markers; a 3D fix (which moves the
marker's state) needs a pair sure in both cameras. Released frames keep their stamps, each
camera's in arrival order.
"""

from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import depth
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.joint3d.assign import NONE, Choice, assign
from dempath_recon.tracking.joint3d.candidates import pair_candidates, pixel_scale
from dempath_recon.tracking.joint3d.grid_fit import fit_grid, pitch_shifts
from dempath_recon.tracking.joint3d.motion import (
    MarkerState,
    MotionModel,
    carry_with_neighbours,
    fix,
    nudge,
    predict,
)
from dempath_recon.tracking.joint3d.options import (
    Predictions,
    pair_options,
    ray_options,
)
from dempath_recon.tracking.records import CameraCounts, PixelFrame, StereoTrackConfig

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]


class Arrival(NamedTuple):
    """A camera's frame waiting for its partner."""

    camera: str
    stamp_s: float
    det: Detections
    events: list[str]
    shake_px: FloatArray | None = None  # (2,) px taken off ``det.uv`` (camera shake)


class JointStereoTracker:
    """Streaming joint two-camera tracker (``StereoTrackConfig.engine = 'joint'``).

    Args:
        cameras: ``{name: camera}`` for the two cameras (calibrated, world frame).
        config: pipeline settings (grid, fps, epipolar gate, fastest marker).
        counts: each camera's counts, shared with the caller's report.
        last_stamp: each camera's last frame's stamp [s] (None before its first), shared
            with the caller (its shake estimator skips the frames this skips).
    """

    AMBIGUITY_MARGIN = 4.0  # a rival detection within this much cost (chi-square) withholds
    GRID_GATE_PITCH = 0.5  # a candidate within this share of the pitch matches a grid point
    GRID_MIN_GAP = 1.0  # the grid fit must lead the one-pitch-shifted fit by this score
    GRID_OFFSET_PITCH = 0.75  # the laid grid is known across the surface to this share of
    # the pitch (the twin's renders: within 3 mm of a 25 mm pitch)
    INIT_SIGMA_PITCH = 0.25  # uncertainty of a grid-placed marker, share of the pitch
    RAY_SIGMA_M = 0.008  # one camera's ray numbers a marker only while it is placed this well

    def __init__(self, cameras: dict[str, Camera], config: StereoTrackConfig,
                 counts: dict[str, CameraCounts],
                 last_stamp: dict[str, float | None] | None = None) -> None:
        self.cameras, self.config, self.counts = cameras, config, counts
        self.names = tuple(cameras)
        self.model = MotionModel(max_speed_m_s=config.max_speed_m_s)
        self.numbers, self.grid_xyz = config.grid.points()
        shifts = pitch_shifts(self.grid_xyz)
        self.pitch_m = float(np.linalg.norm(shifts, axis=1).min()) if len(shifts) else 0.05
        self.states: dict[int, MarkerState] = {}
        self.waiting: dict[str, Arrival] = {}
        self.ready: list[PixelFrame] = []
        self.last_stamp = dict.fromkeys(cameras) if last_stamp is None else last_stamp
        cam_b = cameras[self.names[1]]
        z = float(np.median([depth(cam_b, p) for p in self.grid_xyz]))
        self.px_per_m_b = float(pixel_scale(cam_b, self.grid_xyz[:1])[0]) if z > 0 else 1e3

    def held(self) -> int:
        """Frames waiting for their partner or for ``release``."""
        return len(self.waiting) + len(self.ready)

    def update_detections(self, camera: str, stamp_s: float, det: Detections,
                          shake_px: FloatArray | None = None,
                          events: list[str] | None = None) -> PixelFrame:
        """One frame's detections (``shake_px``: the camera shake already taken off them,
        ``events``: what the caller noted about the frame); returns it as decided now
        (unnumbered while it waits for the other camera's frame; ``release`` gives it out
        once decided)."""
        events = list(events or [])
        if not self._arrive(camera, stamp_s, det, events):
            return PixelFrame(camera, stamp_s, np.zeros(0, np.int32), np.zeros((0, 2)),
                              np.zeros(0), tuple(events))
        here = Arrival(camera, stamp_s, det, events, shake_px)
        mine = self.waiting.pop(camera, None)
        if mine is not None:  # its partner never came
            self._decide([mine])
        other = self.waiting.pop(self._other(camera), None)
        if other is not None and abs(stamp_s - other.stamp_s) < 0.5 / self.config.fps:
            return self._decide([other, here])[-1]
        if other is not None:
            self._decide([other])
        self.waiting[camera] = here
        return unnumbered(here)

    def release(self) -> list[PixelFrame]:
        """The frames decided since the last call, in arrival order per camera."""
        out, self.ready = self.ready, []
        return out

    def flush(self) -> list[PixelFrame]:
        """Decide the frames still waiting (end of a recording) and give everything out."""
        rest = sorted(self.waiting.values(), key=lambda a: a.stamp_s)
        self.waiting.clear()
        if len(rest) == 2 and abs(rest[0].stamp_s - rest[1].stamp_s) < 0.5 / self.config.fps:
            self._decide(rest)
        else:
            for a in rest:
                self._decide([a])
        return self.release()

    def _other(self, camera: str) -> str:
        return self.names[1] if camera == self.names[0] else self.names[0]

    def _arrive(self, camera: str, stamp_s: float, det: Detections, events: list[str]) -> bool:
        """Count the frame; False (skipped) when it is not after the camera's last one."""
        counts, last = self.counts[camera], self.last_stamp[camera]
        if last is not None and stamp_s <= last:
            counts.out_of_order += 1
            msg = f'{camera} frame at {stamp_s:.6f} s is not after {last:.6f} s; skipped'
            LOG.warning(msg)
            events.append(msg)
            return False
        if last is not None and stamp_s - last > 1.5 / self.config.fps:
            missed = max(round((stamp_s - last) * self.config.fps) - 1, 1)
            counts.dropped += missed
            counts.gaps_s.append((last, stamp_s))
            events.append(f'{camera}: {missed} frame(s) missing before {stamp_s:.3f} s')
        self.last_stamp[camera] = stamp_s
        counts.frames += 1
        counts.no_marker += int(len(det.uv) == 0)
        counts.detected += len(det.uv)
        return True

    def _decide(self, arrivals: list[Arrival]) -> list[PixelFrame]:
        """Decide one camera's frame, or both cameras' frames of one instant (in arrival
        order); the frames go to ``ready`` and are returned."""
        by_cam = {a.camera: a for a in arrivals}
        a_name, b_name = self.names
        first = arrivals[0].stamp_s
        ta = by_cam[a_name].stamp_s if a_name in by_cam else first
        tb = by_cam[b_name].stamp_s if b_name in by_cam else first
        uv_a = by_cam[a_name].det.uv if a_name in by_cam else np.zeros((0, 2))
        uv_b = by_cam[b_name].det.uv if b_name in by_cam else np.zeros((0, 2))
        marks: dict[str, NDArray[np.int32]] = {
            n: np.full(len(by_cam[n].det.uv), -1, np.int32) for n in by_cam}
        if not self.states and len(by_cam) == 2:
            self._number_by_grid(uv_a, uv_b, ta, arrivals[-1].events)
        if self.states:
            self._assign(by_cam, (uv_a, uv_b), (ta, tb), marks)
        out = []
        for a in arrivals:
            frame = PixelFrame(a.camera, a.stamp_s, marks[a.camera], a.det.uv,
                               a.det.confidence, tuple(a.events), a.shake_px)
            self.counts[a.camera].tracked += int((frame.markers >= 0).sum())
            self.counts[a.camera].unnumbered += int((frame.markers < 0).sum())
            out.append(frame)
        self.ready += out
        return out

    def _number_by_grid(self, uv_a: FloatArray, uv_b: FloatArray, stamp_s: float,
                        events: list[str]) -> None:
        """Place every marker at its grid point once the grid fits this instant's candidates
        unambiguously (``grid_fit.fit_grid``); otherwise wait (the reason goes to events)."""
        cams = self.cameras[self.names[0]], self.cameras[self.names[1]]
        cand = pair_candidates(cams[0], cams[1], uv_a, uv_b, self.config.epipolar_px)
        offset, why = fit_grid(self.grid_xyz, cand, self.GRID_GATE_PITCH * self.pitch_m,
                               self.config.min_grid_markers, self.GRID_MIN_GAP,
                               self.GRID_OFFSET_PITCH * self.pitch_m)
        events.append(f'joint grid at {stamp_s:.3f} s: {why}')
        if offset is None:
            return
        sigma = self.INIT_SIGMA_PITCH * self.pitch_m
        self.states = {int(m): MarkerState(np.asarray(p + offset, np.float64), stamp_s=stamp_s,
                                           fixed_s=stamp_s, sigma0_m=sigma)
                       for m, p in zip(self.numbers, self.grid_xyz, strict=True)}

    def _assign(self, by_cam: dict[str, Arrival], uv: tuple[FloatArray, FloatArray],
                stamps: tuple[float, float], marks: dict[str, NDArray[np.int32]]) -> None:
        """The joint assignment of one instant; fills ``marks`` and moves the states."""
        a_name, b_name = self.names
        cams = self.cameras[a_name], self.cameras[b_name]
        numbers = sorted(self.states)
        pa = [predict(self.model, self.states[m], stamps[0]) for m in numbers]
        pb = [predict(self.model, self.states[m], stamps[1]) for m in numbers]
        pred = Predictions(np.array([p for p, _ in pa]), np.array([p for p, _ in pb]),
                           np.array([max(s, t) for (_, s), (_, t) in zip(pa, pb, strict=True)]))
        allowance = self.config.max_speed_m_s * abs(stamps[0] - stamps[1]) * self.px_per_m_b
        cand = pair_candidates(cams[0], cams[1], uv[0], uv[1],
                               self.config.epipolar_px + allowance)
        options = pair_options(cams, uv, cand, pred, self.config.epipolar_px)
        options += ray_options(cams[0], 0, uv[0], pred.at_a, pred.sigma_m)
        options += ray_options(cams[1], 1, uv[1], pred.at_b, pred.sigma_m)
        caps = [caps_of(by_cam[n].det) if n in by_cam else np.zeros(0, np.int64)
                for n in self.names]
        choices = assign(options, caps[0], caps[1], self.AMBIGUITY_MARGIN)
        fixed: set[int] = set()
        for idx, choice in sorted(choices.items()):
            m = numbers[idx]
            if self._place(m, choice, by_cam, stamps, pred.sigma_m[idx], marks):
                fixed.add(m)
        carry_with_neighbours(self.model, self.states, fixed, stamps[0])

    def _place(self, marker: int, choice: Choice, by_cam: dict[str, Arrival],
               stamps: tuple[float, float], sigma_m: float,
               marks: dict[str, NDArray[np.int32]]) -> bool:
        """Give out one marker's points and move its state; True when it got a 3D fix."""
        opt, state = choice.option, self.states[marker]
        sure = []
        for k, (det, ok) in enumerate(((opt.det_a, choice.sure_a), (opt.det_b, choice.sure_b))):
            if det == NONE:
                continue
            name = self.names[k]
            arrival = by_cam[name]
            crowded = arrival.det.crowded is not None and bool(arrival.det.crowded[det])
            if not ok or crowded:
                self.counts[name].withheld += int(not ok)
                self.counts[name].merged += int(crowded)
                why = 'a rival spot is nearly as likely' if not ok else 'its spot holds two'
                arrival.events.append(f'{name}: marker {marker} withheld at '
                                      f'{arrival.stamp_s:.3f} s: {why}')
                continue
            sure.append((k, det))
        pair = opt.det_a != NONE and opt.det_b != NONE
        if pair and len(sure) == 2:
            fix(self.model, state, stamps[0], opt.xyz)
        elif len(sure) == 1 and not pair:
            nudge(state, stamps[sure[0][0]], opt.xyz)
        ray_ok = state.fixes > 0 and sigma_m <= self.RAY_SIGMA_M
        for k, det in sure:
            if pair or ray_ok:
                marks[self.names[k]][det] = marker
        return pair and len(sure) == 2


def caps_of(det: Detections) -> NDArray[np.int64]:
    """(n,) how many markers each detection may serve: two for a spot the detector flags as
    two touching markers, one otherwise."""
    caps = np.ones(len(det.uv), np.int64)
    if det.crowded is not None:
        caps += det.crowded.astype(np.int64)
    return caps


def unnumbered(arrival: Arrival) -> PixelFrame:
    """The frame with no point numbered (while it waits for its partner)."""
    return PixelFrame(arrival.camera, arrival.stamp_s, np.full(len(arrival.det.uv), -1, np.int32),
                      arrival.det.uv, arrival.det.confidence, tuple(arrival.events),
                      arrival.shake_px)
