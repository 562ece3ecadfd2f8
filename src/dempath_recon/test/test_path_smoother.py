"""Each numbered marker's image path smoothed over the whole pass (``tracking.path_smoother``):
noise taken off a smooth path, a clean path left as it is, never across a gap or a jump, and
no number or unnumbered point touched.

The paths are drawn in pixels at 50 frames per second (two cameras 3 ms apart), with seeded
Gaussian noise, so each point's true centre is known.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from dempath_recon.tracking.path_smoother import smooth_paths
from dempath_recon.tracking.records import PixelFrame

FPS = 50.0
FRAMES = 40
CAMS = (('cam_side', 0.0), ('cam_front', 0.003))  # (name, stamp offset [s])
Path = Callable[[float, int], np.ndarray]  # (time [s], marker) -> (2,) px


def _path(t: float, m: int) -> np.ndarray:
    """Marker ``m``'s true centre at ``t`` [px]: a slow curve (the sand carried)."""
    return np.array([300.0 + 40 * m + 120 * t + 60 * t * t, 500.0 - 30 * m + 40 * np.sin(3 * t)])


def _frames(path: Path, noise_px: float, seed: int, markers: int = 6,
            skip: Callable[[int, int], bool] = lambda k, m: False,
            ) -> tuple[list[PixelFrame], list[np.ndarray]]:
    """Both cameras' frames (numbered points plus one unnumbered spot each) and each frame's
    true centres; ``skip(k, m)``: marker m not numbered in frame k."""
    rng = np.random.default_rng(seed)
    frames, truth = [], []
    for k in range(FRAMES):
        for cam, offset in CAMS:
            t = k / FPS + offset
            ms = [m for m in range(1, markers + 1) if not skip(k, m)]
            true = np.array([path(t, m) for m in ms] + [[50.0, 50.0]])
            uv = true + rng.normal(0.0, noise_px, true.shape)
            frames.append(PixelFrame(cam, t, np.array([*ms, -1], np.int32), uv,
                                     np.ones(len(uv)), ()))
            truth.append(true)
    return frames, truth


def _rms(frames: list[PixelFrame], truth: list[np.ndarray]) -> float:
    """RMS error [px] of the numbered points against their true centres."""
    err = np.concatenate([(f.uv - t)[f.markers >= 0] for f, t in zip(frames, truth,
                                                                    strict=True)])
    return float(np.sqrt((err ** 2).sum(axis=1).mean()))


def test_noise_is_taken_off_a_smooth_path() -> None:
    """0.5 px of noise per axis on a smooth path: the smoothed centres lie nearer the truth."""
    frames, truth = _frames(_path, 0.5, seed=1)
    with np.errstate(all='raise', under='ignore'):
        out = smooth_paths(frames, FPS)
    assert _rms(out, truth) < 0.75 * _rms(frames, truth), (_rms(frames, truth),
                                                             _rms(out, truth))


def test_a_clean_path_stays() -> None:
    """With almost no noise (0.01 px) the smoother moves no centre by more than 0.05 px."""
    frames, truth = _frames(_path, 0.01, seed=2)
    out = smooth_paths(frames, FPS)
    moved = max(float(np.abs(a.uv - b.uv).max()) for a, b in zip(out, frames, strict=True))
    assert moved < 0.05, moved
    assert _rms(out, truth) < 0.05


def test_numbers_and_unnumbered_points_stay() -> None:
    """Same frames, same numbers, same stamps; the unnumbered spot is not moved."""
    frames, _ = _frames(_path, 0.5, seed=3)
    out = smooth_paths(frames, FPS)
    assert [(f.camera, f.stamp_s) for f in out] == [(f.camera, f.stamp_s) for f in frames]
    for a, b in zip(out, frames, strict=True):
        assert np.array_equal(a.markers, b.markers)
        assert np.array_equal(a.uv[a.markers < 0], b.uv[b.markers < 0])


def test_a_jump_pulls_no_neighbour() -> None:
    """Marker 1 jumps 15 px at frame 20 (a strike): the points either side of it stay within
    the noise of their truth, as on a path without a jump."""
    def struck(t: float, m: int) -> np.ndarray:
        return _path(t, m) + (np.array([15.0, 0.0]) if m == 1 and t >= 20 / FPS else 0.0)

    frames, truth = _frames(struck, 0.3, seed=4)
    out = smooth_paths(frames, FPS)
    near = [k for k, f in enumerate(out) if 18 <= round(f.stamp_s * FPS) <= 21]
    err = [float(np.linalg.norm(out[k].uv[0] - truth[k][0])) for k in near]
    assert max(err) < 1.5, err


def test_never_across_a_gap() -> None:
    """Marker 2 is not numbered in frames 10-14, and 2 px off its path before the gap only:
    the points after the gap keep their own level (smoothed within their own run)."""
    def shifted(t: float, m: int) -> np.ndarray:
        return _path(t, m) + (np.array([0.0, 2.0]) if m == 2 and t < 10 / FPS else 0.0)

    frames, truth = _frames(shifted, 0.2, seed=5, skip=lambda k, m: m == 2 and 10 <= k < 15)
    out = smooth_paths(frames, FPS)
    after = [k for k, f in enumerate(out) if 15 <= round(f.stamp_s * FPS) <= 17]
    rows = [int(np.flatnonzero(out[k].markers == 2)[0]) for k in after]
    err = [float(np.linalg.norm(out[k].uv[r] - truth[k][r])) for k, r in zip(after, rows,
                                                                               strict=True)]
    assert max(err) < 0.6, err


def test_a_short_run_stays_as_measured() -> None:
    """A marker numbered in two frames only keeps its two centres."""
    frames, _ = _frames(_path, 0.5, seed=6, skip=lambda k, m: m == 3 and k not in (7, 8))
    out = smooth_paths(frames, FPS)
    for a, b in zip(out, frames, strict=True):
        assert np.array_equal(a.uv[a.markers == 3], b.uv[b.markers == 3])
