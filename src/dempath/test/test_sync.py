"""The one stamp synchroniser: streaming core, batch form, and that they agree."""

from __future__ import annotations

import numpy as np
import pytest

from dempath.sync import StampSync, sync_stamps


def stamps(n: int, period: float, jitter: float, drop: set[int], seed: int) -> list[float]:
    """``n`` frame stamps [s] every ``period`` with uniform jitter, frames in ``drop`` absent."""
    rng = np.random.default_rng(seed)
    return [k * period + rng.uniform(-jitter, jitter) for k in range(n) if k not in drop]


def test_pairs_nearest_frames_within_slop() -> None:
    """50 fps with 3 ms jitter and slop 8 ms: each instant pairs with itself, the rest alone."""
    a = stamps(40, 0.02, 0.003, drop={5}, seed=0)
    b = stamps(40, 0.02, 0.003, drop={9, 10}, seed=1)
    pairs, alone_a, alone_b = sync_stamps(a, b, slop_s=0.008)
    assert len(pairs) == 37
    assert all(round(a[i] / 0.02) == round(b[j] / 0.02) for i, j in pairs)
    assert [round(a[i] / 0.02) for i in alone_a] == [9, 10]
    assert [round(b[j] / 0.02) for j in alone_b] == [5]


def test_every_frame_leaves_once() -> None:
    """Irregular streams: each frame is in exactly one pair or alone, pairs within the slop."""
    rng = np.random.default_rng(4)
    a, b = np.sort(rng.uniform(0, 2, 60)), np.sort(rng.uniform(0, 2, 45))
    pairs, alone_a, alone_b = sync_stamps(a, b, slop_s=0.01)
    assert sorted([i for i, _ in pairs] + alone_a) == list(range(len(a)))
    assert sorted([j for _, j in pairs] + alone_b) == list(range(len(b)))
    assert all(abs(a[i] - b[j]) <= 0.01 for i, j in pairs)


@pytest.mark.parametrize('mutual', [False, True])
def test_streaming_and_batch_agree(mutual: bool) -> None:
    """Frames fed one at a time to StampSync.update pair exactly as the batch form."""
    a = stamps(30, 0.02, 0.004, drop=set(), seed=2)
    b = stamps(30, 0.02, 0.004, drop={3}, seed=3)
    batch, alone_a, alone_b = sync_stamps(a, b, slop_s=0.009, wait_for_nearest=mutual)
    sync: StampSync[int] = StampSync(0.009, wait_for_nearest=mutual)
    arrivals = sorted([(t, 0, i) for i, t in enumerate(a)] + [(t, 1, j) for j, t in enumerate(b)])
    events = [e for t, k, i in arrivals for e in sync.update(k, t, i)] + sync.flush()
    streamed = [p for e in events if (p := e.pair()) is not None]
    assert streamed == batch
    assert sync.unpaired == len(alone_a) + len(alone_b) == 1


def mutual_nearest(a: list[float], b: list[float], slop_s: float) -> list[tuple[int, int]]:
    """Slow, obvious reference: pairs that are each other's nearest (ties: earlier frame)."""
    def nearest(t: float, others: list[float]) -> int:
        return min(range(len(others)), key=lambda j: (abs(others[j] - t), others[j]))

    return sorted((i, j) for i, t in enumerate(a) if b
                  for j in [nearest(t, b)] if nearest(b[j], a) == i and abs(b[j] - t) <= slop_s)


@pytest.mark.parametrize('seed', range(5))
def test_mutual_mode_is_mutual_nearest(seed: int) -> None:
    """Irregular clocks of different rates: the mutual mode gives the reference's pairs."""
    rng = np.random.default_rng(seed)
    a = sorted(rng.uniform(0, 3, 90).tolist())
    b = sorted(rng.uniform(0, 3, 70).tolist())
    pairs, _, _ = sync_stamps(a, b, slop_s=0.02)
    assert sorted(pairs) == mutual_nearest(a, b, 0.02)


def test_modes_agree_at_one_frame_rate() -> None:
    """One frame rate, slop under half the period: live and mutual modes pair alike."""
    a = stamps(50, 0.02, 0.004, drop={7, 8}, seed=5)
    b = stamps(50, 0.02, 0.004, drop={20}, seed=6)
    assert sync_stamps(a, b, 0.009, wait_for_nearest=False) == sync_stamps(a, b, 0.009)


def test_full_queue_lets_the_oldest_go() -> None:
    """Frames of one stream beyond queue_size leave alone, counted, oldest first."""
    sync: StampSync[str] = StampSync(0.001, queue_size=2)
    out = [e for k in range(3) for e in sync.update(0, 0.1 * k, f'a{k}')]
    assert [e.items for e in out] == [('a0', None)]
    assert sync.unpaired == 1
    assert [e.items for e in sync.flush()] == [('a1', None), ('a2', None)]


def test_bad_settings_are_refused() -> None:
    """Negative slop, an empty queue and an unknown stream raise with the field named."""
    with pytest.raises(ValueError, match='slop_s'):
        StampSync(-1.0)
    with pytest.raises(ValueError, match='queue_size'):
        StampSync(0.01, queue_size=0)
    with pytest.raises(ValueError, match='stream'):
        StampSync(0.01).update(2, 0.0, 'x')
