"""Pairing of the two cameras' detection streams by time (stamps: dempath.sync)."""

from __future__ import annotations

import numpy as np

from dempath_calib.pairing import DetectionStream, pair_frames

N = 4  # corners on the toy board


def moving_corners(t: float) -> np.ndarray:
    """(N, 2) px of a board moving at 100 px/s along u: a known, linear truth."""
    return np.stack([np.arange(N) * 10.0 + 100.0 * t, np.full(N, 50.0)], axis=1)


def test_front_interpolated_to_side_instants() -> None:
    """Front exposes 10 ms after the side: its corners come back at the side's instants."""
    side, front = DetectionStream(N), DetectionStream(N)
    for k in range(20):
        side.add(0.04 * k, moving_corners(0.04 * k))
        front.add(0.04 * k + 0.01, moving_corners(0.04 * k + 0.01))
    stamps, corners = pair_frames(side, front)
    paired = ~np.isnan(corners[:, 1, 0, 0]) & ~np.isnan(corners[:, 0, 0, 0])
    assert paired.sum() == 19  # the first side frame has no front frame before it
    for t, c in zip(stamps[paired], corners[paired], strict=True):
        assert np.allclose(c[0], moving_corners(t))
        assert np.allclose(c[1], moving_corners(t))


def test_unpaired_frames_kept_with_nan() -> None:
    """A front frame with no side frame near it stays, with NaN for the side camera."""
    side, front = DetectionStream(N), DetectionStream(N)
    for k in range(5):
        side.add(0.1 * k, moving_corners(0.1 * k))
    front.add(0.2, moving_corners(0.2))
    front.add(0.75, moving_corners(0.75))
    stamps, corners = pair_frames(side, front, tol_s=0.01, interpolate=False)
    assert len(stamps) == 6
    alone = np.isclose(stamps, 0.75)
    assert np.isnan(corners[alone, 0]).all()
    assert np.allclose(corners[alone, 1], moving_corners(0.75))
    assert np.allclose(corners[np.isclose(stamps, 0.2), 1], moving_corners(0.2))
