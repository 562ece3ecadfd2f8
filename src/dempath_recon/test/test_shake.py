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


def calibration_frame(base: NDArray[np.float32], k: int) -> bytes:
    """Calibration view ``k``: the ground as calibrated (no shift), a bright board held at a
    place of its own in each view, JPEG 90."""
    img = base.copy()
    x0, y0 = 60 + (k * 170) % (W - 260), 40 + (k * 110) % (H - 200)
    img[y0:y0 + 160, x0:x0 + 200] = 220.0
    ok, buf = cv2.imencode('.jpg', np.clip(img, 0, 255).astype(np.uint8),
                           [cv2.IMWRITE_JPEG_QUALITY, 90])
    assert ok
    return buf.tobytes()


def test_a_pass_moved_off_the_calibration_is_placed_by_the_calibrations_frames() -> None:
    """A camera knocked 2.5 px right and 1.5 px up since its calibration, then shaking by up
    to 3 px: against the calibration's frames (a board moving across them) each frame's shift
    is measured to 0.2 px RMS and the move is said; by the pass's mean alone (no calibration
    frames) the whole move is missed. The frames' tiles are cut again where the view's content
    went (``align``): cut where the view's were, the window's pull toward zero left 0.31 px."""
    rng = np.random.default_rng(4)
    base = ground(5)
    moved = np.array([2.5, -1.5])
    shifts = moved + rng.uniform(-3.0, 3.0, (20, 2))
    frames = [decode_jpeg(frame(base, k, s), 2) for k, s in enumerate(shifts)]
    placed, alone = ShakeEstimator(align=True), ShakeEstimator(align=True)
    for k in range(6):
        placed.add_reference(decode_jpeg(calibration_frame(base, k), 2), 2.0)
    rel = np.array([placed.update(f, 2.0).relative_px for f in frames])
    for f in frames:
        alone.update(f, 2.0)
    got = np.array([placed.placed(r, shrink=False) for r in rel])
    err = np.sqrt(((got - shifts) ** 2).sum(1).mean())
    assert err < 0.2, got - shifts
    offset = placed.view_offset_px
    assert offset is not None and np.linalg.norm(offset - shifts.mean(0)) < 0.2, offset
    by_mean = np.array([alone.placed(r, shrink=False) for r in rel])
    assert np.sqrt(((by_mean - shifts) ** 2).sum(1).mean()) > 2.5
    assert alone.view_offset_px is None


def test_the_estimates_own_noise_is_not_taken_for_shake() -> None:
    """A still camera under heavy read noise: much of the shifts' scatter is the estimate's
    own noise, its gain is below one and the placed shifts scatter less than the estimated
    ones (the split tiles see only part of that noise: the gain stays about 0.7); a shaking
    camera keeps a gain near one."""
    rng = np.random.default_rng(6)
    base = ground(7)

    def noisy(shift: NDArray[np.float64], k: int) -> NDArray[np.uint8]:
        img = cv2.imdecode(np.frombuffer(frame(base, k, shift), np.uint8), cv2.IMREAD_COLOR)
        img = img.astype(np.float32) + rng.normal(0.0, 12.0, img.shape).astype(np.float32)
        ok, buf = cv2.imencode('.jpg', np.clip(img, 0, 255).astype(np.uint8),
                               [cv2.IMWRITE_JPEG_QUALITY, 60])
        assert ok
        return decode_jpeg(buf.tobytes(), 2)

    still = ShakeEstimator()
    rel = np.array([still.update(noisy(np.zeros(2), k), 2.0).relative_px for k in range(16)])
    assert (still.gain < 0.9).all(), still.gain
    raw = np.array([still.placed(r, shrink=False) for r in rel])
    shrunk = np.array([still.placed(r, shrink=True) for r in rel])
    rms_raw, rms_shrunk = (np.sqrt((x ** 2).sum(1).mean()) for x in (raw, shrunk))
    assert rms_shrunk < 0.85 * rms_raw, (rms_shrunk, rms_raw)
    shaking = ShakeEstimator()
    for k, s in enumerate(rng.uniform(-3.0, 3.0, (16, 2))):
        shaking.update(noisy(s, k), 2.0)
    assert (shaking.gain > 0.95).all(), shaking.gain
