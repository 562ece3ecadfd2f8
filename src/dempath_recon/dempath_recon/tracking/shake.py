"""Camera shake: each frame's image motion, from the parts of the view that do not move.

A camera on an implement vibrates: its image moves a few pixels from frame to frame while the
calibration stays, so every marker of a frame sits off by the same shift, the pairs leave their
epipolar lines and the 3D points move by millimetres. :class:`ShakeEstimator` measures one
camera's image translation in every frame, from the images alone, and
:func:`remove_shake` moves the frame's detections back before linking, the pair checks and
triangulation.

How: the frame is made grey and small (a quarter of full size: shifts of a few pixels are
about one small pixel), cut into square tiles (128 full-size pixels), and each tile is
registered against the same tile of the camera's first frame by phase correlation (the
normalised cross-power spectrum's peak; Kuglin & Hines 1975), which ignores the light's gain in
a tile. Most tiles hold ground or bin walls that stay where they are; the tiles of the tool,
of the sand it moves and of the markers give other shifts, and tiles whose correlation peak is
low (flat, or noise alone) say nothing. The frame's shift is the mean of the tiles within
``INLIER_PX`` of their median, refined twice more with the correlation peaks moved back by
the estimate so far (a phase ramp on the cross-power spectra, no image resampled): the peak's
parabolic sub-pixel fit is biased toward whole pixels, and one pass left about a fifth of the
shift (0.49 px RMS on the tuned 3 px shake), two 0.30, three 0.23; Foroosh's sinc fit did well
on one pass (0.19 px) but is biased near whole pixels (0.66 px on the unshaken noisy
variation against 0.13). If fewer
than ``MIN_SHARE`` of the tiles (and ``MIN_TILES``) agree, the view has no fixed part to hold
on to (the tool fills it, fog, darkness): the frame's shake is reported unknown and nothing is
corrected.

The first frame is itself shaken, so the registration gives the motion relative to it; the
calibration's view is taken as the mean of the frames registered so far (vibration about the
mounting: zero mean), so the correction of frame ``k`` is its relative shift minus the running
mean of the relative shifts of frames 0..k; a frame given out later
(``StereoMarkerTracker.release``, the publication delay) is placed again by the mean of the
frames till then (``anchor_px``), only a common offset of its points; with the whole pass held
(``StereoTrackConfig.whole_pass``, the offline path and the lossless node graph) every frame is
placed at the end by the mean of all the pass's frames (on ``shake_3px``: 1.3 and 1.1 px RMS
against the true shifts at arrival, 1.0 and 0.8 after a 5-frame delay, 0.7 and 0.4 from the
whole pass; the variation's 3D RMS 2.89 -> 2.24 mm). Streaming, one
camera's frames in order: the same frames give the same corrections whatever the other camera
does (the lossless node graph equals the offline path). Only a translation: a rotation of the
image (roll) or a slow drift away from the calibration and back is not modelled.

The pass's mean is only the calibration's view if the shake averages out over the pass: a
camera knocked since its calibration, or a short pass (``shake_3px``'s 31 frames left 0.7 px
in one axis, 1.7 of its 2.2 mm), is not. Given the frames the calibration was made on
(:meth:`ShakeEstimator.add_reference`, ``StereoTrackConfig.shake_reference``), their per-pixel
median (a board moved between the views leaves it) is the view, and the pass's first
``ANCHOR_FRAMES`` frames are registered against it too: the view is placed by measurement, and
:attr:`ShakeEstimator.view_offset_px` says how far the pass sits off it. The pairs' epipolar
residuals do not replace it: they see one of the four offsets of a camera pair, and that one
is the one triangulation drops (session 26: on ``shake_3px`` the residual gave that component
to 0.03 px and the 3D RMS stayed 2.16 mm).

Each frame's estimate carries its own noise (about 0.1 px under noise 6 and JPEG 60, on a
camera that does not shake at all). With ``StereoTrackConfig.shake_shrink`` a frame's departure
from the pass's mean is scaled by :attr:`ShakeEstimator.gain`, the share of the departures'
variance that is not that noise (the Wiener gain of a white signal in white noise), the noise
measured on each frame by splitting its agreeing tiles in two (``ShakeEstimate.split_px``).
"""

from __future__ import annotations

import logging
from typing import NamedTuple

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy import fft

from dempath_recon.tracking.detect import Detections

FloatArray = NDArray[np.float64]
LOG = logging.getLogger(__name__)


class ShakeEstimate(NamedTuple):
    """One frame's image motion.

    Attributes:
        shift_px: (2,) the image's translation (u, v) against the calibration's view [px,
            full size]; NaN when it could not be estimated.
        relative_px: (2,) the translation against the camera's first frame [px, full size]
            (NaN: not estimated); ``relative_px - ShakeEstimator.anchor_px`` places it against
            the calibration's view as known later.
        agreeing: tiles whose registration agreed with the frame's shift.
        tiles: tiles registered.
        split_px: (2,) the mean shift of every other agreeing tile less that of the rest
            [px, full size]: its variance over the pass is four times the estimate's
            (:meth:`ShakeEstimator.placed`); NaN: not estimated.
    """

    shift_px: FloatArray
    agreeing: int
    tiles: int
    relative_px: FloatArray
    split_px: FloatArray = np.full(2, np.nan)

    @property
    def known(self) -> bool:
        """Whether the frame's shift was estimated."""
        return bool(np.isfinite(self.shift_px).all())


class ShakeEstimator:
    """Per-frame image translation of one camera (streaming: frames in stamp order)."""

    WIDTH = 480  # the registered image's width [px] (a quarter of 1920)
    TILE = 32  # tile side in the registered image (128 full-size px)
    INLIER_PX = 0.5  # a tile agrees within this of the tiles' median [registered px]
    MIN_SHARE = 0.3  # share of the tiles that must agree (the tool and the moved sand
    # covered 6-12 % of the 120 tiles on the bundled render)
    MIN_TILES = 8  # and at least this many
    MIN_PEAK = 0.1  # a tile's correlation peak below this says nothing (a flat tile: 0; noise
    # alone: about 0.1 at most; ground and bin walls on the tuned variations: 99 % above 0.12)
    PASSES = 3  # registrations, each with the tiles' peaks moved back by the estimate so far
    # (about 0.6 ms each on this machine; the tiles' spectra are taken once)

    MARGIN = 8  # the farthest such a cut moves [small px] (32 full-size px: shake, not a pan)
    MIN_SPREAD_FRAMES = 10  # frames before the estimate's noise is weighed (:attr:`gain`)
    ANCHOR_FRAMES = 10  # the pass's first frames also registered against the calibration's
    # view (``add_reference``); their mean places that view (one registration's error is about
    # 0.1-0.2 px: ten give a few hundredths; the view seen later holds more moved sand)

    def __init__(self, align: bool = False) -> None:
        """Args:
            align: cut the frame's tiles again where the reference's content went (whole
                small px) after the first registration (:meth:`_measure`).
        """
        self.align = align
        self._ref: NDArray[np.complex64] | None = None
        self._window = np.outer(np.hanning(self.TILE), np.hanning(self.TILE)).astype(np.float32)
        self._sum = np.zeros(2)
        self._count = 0
        self._sq_sum = np.zeros(2)  # sum of the relative shifts' squares [px^2]
        self._split_sq = np.zeros(2)  # sum of the split differences' squares [px^2]
        self._split_count = 0
        self._views: list[NDArray[np.float32]] = []  # the calibration's frames, small grey
        self._view: NDArray[np.complex64] | None = None  # their median's tile spectra
        self._view_scale = 1.0  # full-size px per small px of those frames
        self._anchor_sum = np.zeros(2)  # sum of (relative - against the view) [px, full size]
        self._anchor_count = 0
        self._kx = np.fft.rfftfreq(self.TILE)[None, :]  # cycles per small px, across
        self._ky = np.fft.fftfreq(self.TILE)[:, None]  # and down

    def update(self, image: NDArray[np.uint8], full_per_px: float) -> ShakeEstimate:
        """This frame's shift against the calibration's view.

        Args:
            image: (h, w, 3) BGR or (h, w) grey frame, at any scale.
            full_per_px: full-size pixels per pixel of ``image`` (2 for a half-size decode).
        """
        small, scale = self._small(image, full_per_px)
        spectra = self._spectra(small)
        if self._ref is None:
            self._ref = spectra
        if len(spectra) != len(self._ref):
            msg = f'frame of {small.shape} small px does not match the first frame of this camera'
            raise ValueError(msg)
        found, agreeing, split = self._measure(small, spectra, self._ref)
        if found is None:
            return ShakeEstimate(np.full(2, np.nan), agreeing, len(spectra), np.full(2, np.nan))
        rel = found * scale
        self._sum += rel
        self._count += 1
        self._sq_sum += rel * rel
        split = split * scale
        if np.isfinite(split).all():
            self._split_sq += split * split
            self._split_count += 1
        self._place_view(small, spectra, scale, rel)
        return ShakeEstimate(rel - self.anchor_px, agreeing, len(spectra), rel, split)

    def add_reference(self, image: NDArray[np.uint8], full_per_px: float) -> None:
        """One frame of the images the calibration was made on (before the pass's first
        frame): their per-pixel median is the calibration's view, against which the pass is
        placed (:attr:`anchor_px`). A board moved between the views leaves the median."""
        if self._ref is not None:
            msg = "the calibration's frames go in before the pass's first frame"
            raise ValueError(msg)
        small, self._view_scale = self._small(image, full_per_px)
        self._views.append(small)

    @property
    def anchor_px(self) -> FloatArray:
        """(2,) the calibration's view against the first frame [px, full size]: measured
        against the calibration's frames when given (``add_reference``: the mean over the
        pass's first ``ANCHOR_FRAMES`` frames registered against that view), else the mean of
        the relative shifts so far (the shake's mean over the pass taken as zero; zero before
        any frame)."""
        if self._anchor_count:
            return self._anchor_sum / self._anchor_count
        return self._sum / max(self._count, 1)

    @property
    def gain(self) -> FloatArray:
        """(2,) the share of each axis's scatter about the pass's mean that is the image's
        motion and not the estimate's noise: ``max(0, 1 - n / v)``, ``v`` the relative
        shifts' variance so far and ``n`` the estimate's own (a quarter of the split
        differences' mean square); the Wiener gain of a white signal in white noise. Ones
        before ``MIN_SPREAD_FRAMES`` frames."""
        if self._count < self.MIN_SPREAD_FRAMES or self._split_count < self.MIN_SPREAD_FRAMES:
            return np.ones(2)
        mean = self._sum / self._count
        var = self._sq_sum / self._count - mean * mean
        noise = self._split_sq / self._split_count / 4.0
        return np.asarray(np.clip(1.0 - noise / np.maximum(var, 1e-12), 0.0, 1.0), np.float64)

    def placed(self, relative_px: FloatArray, shrink: bool) -> FloatArray:
        """(2,) a frame's shift against the calibration's view as known now [px, full size]
        from its shift against the first frame; ``shrink``: its departure from the pass's
        mean scaled by :attr:`gain` (on a camera that does not shake, the estimate's noise
        moved every frame's points by about 0.1 px under noise 6 and JPEG 60)."""
        if not shrink or not self._count:
            return np.asarray(relative_px - self.anchor_px, np.float64)
        mean = self._sum / self._count
        return np.asarray((relative_px - mean) * self.gain + mean - self.anchor_px, np.float64)

    @property
    def view_offset_px(self) -> FloatArray | None:
        """(2,) the pass's mean image position against the calibration's view [px, full
        size]: a camera moved since it was calibrated (None: no calibration frames, or none
        of the pass's frames placed against them)."""
        if not self._anchor_count or not self._count:
            return None
        return np.asarray(self._sum / self._count - self.anchor_px, np.float64)

    def _place_view(self, small: NDArray[np.float32], spectra: NDArray[np.complex64],
                    scale: float, rel: FloatArray) -> None:
        """Register one of the pass's first frames against the calibration's view too: the
        difference of its shift against the first frame and against that view is where the
        view lies against the first frame."""
        if not self._views or self._anchor_count >= self.ANCHOR_FRAMES:
            return
        if self._view is None:
            view = np.median(np.stack(self._views), axis=0).astype(np.float32)
            if view.shape[0] // self.TILE * (view.shape[1] // self.TILE) != len(spectra) \
                    or abs(self._view_scale - scale) > 1e-9:
                LOG.warning("calibration frames of %s small px do not match the pass's "
                            'frames: the shake is placed by its mean over the pass', view.shape)
                self._views = []
                return
            self._view = self._spectra(view)
        shift, _, _ = self._measure(small, spectra, self._view)
        if shift is None:
            return
        self._anchor_sum += rel - shift * scale
        self._anchor_count += 1

    def _small(self, image: NDArray[np.uint8], full_per_px: float,
               ) -> tuple[NDArray[np.float32], float]:
        """The grey frame at ``WIDTH`` (or less), and full-size px per small px."""
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
        h, w = grey.shape
        f = max(1, w // self.WIDTH)
        if f > 1:
            grey = cv2.resize(grey, (w // f, h // f), interpolation=cv2.INTER_AREA)
        return grey.astype(np.float32), full_per_px * f

    def _measure(self, small: NDArray[np.float32], spectra: NDArray[np.complex64],
                 ref: NDArray[np.complex64]) -> tuple[FloatArray | None, int, FloatArray]:
        """The frame's shift against the reference's tiles [small px] (None: too few
        agree), how many tiles agree, and the split difference (:meth:`_register`).

        ``spectra`` are the frame's tiles cut where the reference's were: the window stays
        while the content moves, which pulls the correlation peak toward zero (about 6 % of
        the shift). So once the shift is roughly known the frame's tiles are cut again where
        the reference's content went, moved by the shift's whole small pixels (``align``), and
        only the fraction left is registered (0.31 -> 0.14 px RMS on this module's test of a
        camera knocked by 3 px; on ``shake_3px``, whose shifts are bilinear warps, the error
        that stays follows the shift's fraction of a pixel)."""
        shift: FloatArray = np.zeros(2)
        agreeing = 0
        split: FloatArray = np.full(2, np.nan)
        cut: FloatArray = np.zeros(2)  # where the frame's tiles are cut [whole small px]
        found: FloatArray | None
        cross = _normalised(spectra * ref.conj())
        for k in range(self.PASSES):
            found, agreeing, split = self._register(cross, shift - cut)
            if found is None:
                return None, agreeing, split
            shift = shift + found
            if k == 0 and self.align:
                cut = np.clip(np.round(shift), -self.MARGIN, self.MARGIN)
                if cut.any():
                    cross = _normalised(self._spectra(small, cut) * ref.conj())
        return shift, agreeing, split

    def _spectra(self, small: NDArray[np.float32], at: FloatArray | None = None,
                 ) -> NDArray[np.complex64]:
        """(n, t, t // 2 + 1) windowed spectra of the frame's tiles, cut at their places
        moved by ``at`` (u, v) whole small px (the frame's edge mirrored beyond it)."""
        t = self.TILE
        ny, nx = small.shape[0] // t, small.shape[1] // t
        if at is not None and at.any():
            m, (du, dv) = self.MARGIN, at.astype(int)
            padded = np.asarray(cv2.copyMakeBorder(small, m, m, m, m, cv2.BORDER_REFLECT),
                                np.float32)
            small = padded[m + dv:m + dv + ny * t, m + du:m + du + nx * t]
        tiles = small[:ny * t, :nx * t].reshape(ny, t, nx, t).swapaxes(1, 2).reshape(-1, t, t)
        tiles = tiles - tiles.mean(axis=(1, 2), keepdims=True)
        return np.asarray(fft.rfft2(tiles * self._window, workers=1), np.complex64)

    def _register(self, cross: NDArray[np.complex64], shift: FloatArray,
                  ) -> tuple[FloatArray | None, int, FloatArray]:
        """The tiles' common shift beyond ``shift`` [small px] (None if too few agree), how
        many agree, and the mean shift of every other agreeing tile less the rest's [small
        px]. ``cross``: (n, t, t // 2 + 1) the tiles' normalised cross-power
        spectra; multiplied by the phase ramp of ``-shift``, their correlation peaks move from
        ``shift`` to near 0, where the parabolic fit is least biased (no image is resampled)."""
        t = self.TILE
        if shift.any():
            ramp = np.exp(2j * np.pi * (self._kx * shift[0] + self._ky * shift[1]))
            cross = cross * ramp.astype(np.complex64)
        surface = fft.irfft2(cross, s=(t, t), workers=1)
        n, none = len(surface), np.full(2, np.nan)
        if n == 0:
            return None, 0, none
        rows, cols = np.divmod(surface.reshape(n, -1).argmax(axis=1), t)
        at = np.arange(n)
        peak = surface[at, rows, cols]
        du = _vertex(surface[at, rows, (cols - 1) % t], peak, surface[at, rows, (cols + 1) % t])
        dv = _vertex(surface[at, (rows - 1) % t, cols], peak, surface[at, (rows + 1) % t, cols])
        d = np.stack([(cols + t // 2) % t - t // 2 + du, (rows + t // 2) % t - t // 2 + dv], 1)
        strong = peak > self.MIN_PEAK
        if not strong.any():
            return None, 0, none
        near = strong & (np.linalg.norm(d - np.median(d[strong], axis=0), axis=1)
                         < self.INLIER_PX)
        agreeing = int(near.sum())
        if agreeing < max(self.MIN_TILES, self.MIN_SHARE * n):
            return None, agreeing, none
        held = d[near].astype(np.float64)
        return held.mean(axis=0), agreeing, held[0::2].mean(axis=0) - held[1::2].mean(axis=0)


def _normalised(cross: NDArray[np.complex64]) -> NDArray[np.complex64]:
    """The cross-power spectra with unit magnitude (phase correlation)."""
    return np.asarray(cross / (np.abs(cross) + 1e-6), np.complex64)


def _vertex(before: FloatArray, peak: FloatArray, after: FloatArray) -> FloatArray:
    """Sub-sample offset of a peak from its two neighbours (the parabola's vertex)."""
    den = before - 2 * peak + after
    safe = np.where(np.abs(den) > 1e-12, den, 1.0)
    return np.where(np.abs(den) > 1e-12, 0.5 * (before - after) / safe, 0.0)


def remove_shake(det: Detections, shift_px: FloatArray) -> Detections:
    """A frame's detections in the calibration's view: moved back by the frame's shift.

    The faint-spot search (``Detections.faint``) looks in the frame's image, so it is asked
    at the shaken place and its answer moved back the same way; the published marker centres
    (``Detections.centre``) move with the detections.
    """
    shift = np.asarray(shift_px, np.float64)
    if not np.isfinite(shift).all() or not shift.any():
        return det
    faint = det.faint
    if faint is not None:
        inner = faint

        def faint_moved(points: FloatArray, radius_px: float,
                        steps: FloatArray | None = None) -> FloatArray:
            moved = np.asarray(points, np.float64) + shift
            return inner(moved, radius_px, steps) - shift

        faint = faint_moved
    centre = det.centre - shift if det.centre is not None else None
    return det._replace(uv=det.uv - shift, faint=faint, centre=centre)
