"""Approximate time synchronisation and marker-id matching of the two cameras."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_recon.errors import PixelInputError
from dempath_recon.pairing import FRONT, SIDE, PixelFrame, StampPairer, match_ids, pair_frames


def frames(n: int, period: float, jitter: float, drop: set[tuple[int, int]],
           seed: int) -> list[PixelFrame]:
    """Both cameras' frames in arrival order; camera c's frame k is absent when (c, k) in drop."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        for cam in (SIDE, FRONT):
            if (cam, k) in drop:
                continue
            stamp = k * period + rng.uniform(-jitter, jitter)
            ids = np.array([1, 2, 3])
            out.append(PixelFrame(cam, stamp, ids, np.full((3, 2), 100.0 * k + cam)))
    return out


def test_pairs_nearest_frames_within_slop() -> None:
    """50 fps with 3 ms jitter and slop 8 ms: each instant pairs with itself, drops counted."""
    seq = frames(40, 0.02, 0.003, drop={(SIDE, 5), (FRONT, 9), (FRONT, 10)}, seed=0)
    pairs, unpaired = pair_frames(seq, slop_s=0.008)
    assert len(pairs) == 37
    assert unpaired == 3
    for p in pairs:
        k = round(p.stamp_s / 0.02)
        assert np.allclose(p.pixels, [[100.0 * k, 100.0 * k, 100.0 * k + 1, 100.0 * k + 1]] * 3)
        assert abs(p.dt_s) <= 0.008


def test_streaming_and_batch_agree() -> None:
    """Feeding StampPairer.update one frame at a time gives the batch result."""
    seq = frames(30, 0.02, 0.004, drop={(FRONT, 3)}, seed=1)
    batch, _ = pair_frames(seq, slop_s=0.009)
    pairer = StampPairer(0.009)
    stream = [p for f in seq for p in pairer.update(f)]
    assert [p.stamp_s for p in stream] == [p.stamp_s for p in batch]


def test_match_ids_counts_rejections() -> None:
    """Ids seen by one camera only and duplicated ids are dropped with their reason."""
    side = PixelFrame(SIDE, 0.0, np.array([1, 2, 3, 3, 7]), np.arange(10.0).reshape(5, 2))
    front = PixelFrame(FRONT, 0.001, np.array([2, 1, 3, 9]), 100 + np.arange(8.0).reshape(4, 2))
    pair = match_ids(side, front)
    assert list(pair.ids) == [1, 2]
    assert np.allclose(pair.pixels, [[0, 1, 102, 103], [2, 3, 100, 101]])
    assert pair.rejected == {'duplicate marker id': 2, 'marker seen by one camera only': 3}


def test_bad_frames_and_settings_are_refused() -> None:
    """Mismatched ids/points, unknown camera and negative slop raise with the field named."""
    with pytest.raises(PixelInputError, match='marker ids but'):
        PixelFrame(SIDE, 0.0, np.array([1, 2]), np.zeros((3, 2)))
    with pytest.raises(PixelInputError, match='camera'):
        PixelFrame(5, 0.0, np.array([1]), np.zeros((1, 2)))
    with pytest.raises(ValueError, match='slop_s'):
        StampPairer(-1.0)
