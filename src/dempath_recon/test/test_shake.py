"""Camera shake measured on real OpenCV images: a textured ground with a tool crossing it, each
frame moved by a known sub-pixel shift and JPEG-encoded, decoded at half size as the tracker
does (``tracking/shake.py``)."""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.detect import Detections, decode_jpeg
from dempath_recon.tracking.shake import ShakeEstimator, remove_shake

H, W = 540, 960  # full-size frames of this test [px] (half of 1080p: quick)


def ground(seed: int) -> NDArray[np.float32]:
    """(H, W, 3) a soft random ground texture (grey levels 30-90), as the renders' ground."""
    rng = np.random.default_rng(seed)
    grey = cv2.GaussianBlur(rng.normal(0.0, 1.0, (H, W)).astype(np.float32), (0, 0), 3.0)
    grey = 60.0 + 15.0 * grey / grey.std()
    return np.repeat(grey[..., None], 3, axis=2) * np.array([0.8, 1.0, 1.2], np.float32)


def frame(base: NDArray[np.float32], k: int, shift: NDArray[np.float64]) -> bytes:
    """Frame ``k``: a bright tool (a fifth of the width) at its place of frame ``k``, the whole
    image moved by ``shift`` [px], JPEG 90."""
    img = base.copy()
    x0 = 100 + 30 * k
    img[120:420, x0:x0 + W // 5] = 200.0
    m = np.array([[1.0, 0.0, shift[0]], [0.0, 1.0, shift[1]]], np.float32)
    moved = cv2.warpAffine(img, m, (W, H), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    ok, buf = cv2.imencode('.jpg', np.clip(moved, 0, 255).astype(np.uint8),
                           [cv2.IMWRITE_JPEG_QUALITY, 90])
    assert ok
    return buf.tobytes()


def test_each_frames_shift_is_measured_despite_a_moving_tool() -> None:
    """Shifts of up to 3 px a frame: each frame's shift against the mean of the frames so far
    (the calibration's view: vibration about the mounting) measured to 0.2 px RMS, though a
    tool covering a fifth of the view moves 30 px a frame."""
    rng = np.random.default_rng(1)
    base = ground(2)
    shifts = rng.uniform(-3.0, 3.0, (20, 2))
    est = ShakeEstimator()
    got = np.array([est.update(decode_jpeg(frame(base, k, s), 2), 2.0).shift_px
                    for k, s in enumerate(shifts)])
    want = shifts - np.cumsum(shifts, axis=0) / np.arange(1, len(shifts) + 1)[:, None]
    err = np.sqrt(((got - want) ** 2).sum(1).mean())
    assert err < 0.2, got - want
    # without the estimate (no correction) the frames would be off by the shake itself
    assert np.sqrt((want ** 2).sum(1).mean()) > 5 * err


def test_a_view_with_nothing_fixed_is_said_unknown() -> None:
    """Frames of fresh noise (nothing stays from frame to frame) and a flat grey view: no
    shift is given (NaN), rather than 0."""
    rng = np.random.default_rng(3)
    est = ShakeEstimator()
    est.update(rng.integers(0, 255, (H // 2, W // 2, 3), dtype=np.uint8), 2.0)
    noise = est.update(rng.integers(0, 255, (H // 2, W // 2, 3), dtype=np.uint8), 2.0)
    assert not noise.known and noise.agreeing < ShakeEstimator.MIN_TILES, noise
    flat = ShakeEstimator()
    flat.update(np.full((H // 2, W // 2, 3), 90, np.uint8), 2.0)
    again = flat.update(np.full((H // 2, W // 2, 3), 91, np.uint8), 2.0)
    assert not again.known, again


def test_detections_are_moved_back_and_faint_spots_asked_where_seen() -> None:
    """``remove_shake`` takes the shift off the centres; the faint-spot search is asked at the
    place in the image and its answer moved back the same way."""
    asked: list[NDArray[np.float64]] = []

    def faint(points: NDArray[np.float64], radius_px: float,
              steps: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        asked.append(points)
        return points + 0.5  # a spot half a pixel off what was asked

    det = Detections(np.array([[100.0, 50.0]]), np.ones(1), np.ones(1), None, faint)
    out = remove_shake(det, np.array([2.0, -1.0]))
    np.testing.assert_allclose(out.uv, [[98.0, 51.0]])
    assert out.faint is not None
    np.testing.assert_allclose(out.faint(np.array([[98.0, 51.0]]), 4.0), [[98.5, 51.5]])
    np.testing.assert_allclose(asked[0], [[100.0, 50.0]])
    assert remove_shake(det, np.full(2, np.nan)) is det
