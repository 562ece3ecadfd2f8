"""FrameStride: which live frames a detector that falls behind keeps, and what it counts."""

from __future__ import annotations

import pytest

from dempath_recon.stride import FrameStride

FPS = 50.0


def run(stride: FrameStride, waiting: list[int], offset_s: float = 0.0) -> list[int]:
    """Feed frames 0, 1, ... with the given worker backlog each; the frame numbers kept."""
    return [k for k, w in enumerate(waiting) if stride.keep(k / FPS + offset_s, w)]


def test_keeps_every_frame_while_the_worker_keeps_up() -> None:
    """An idle worker: every frame kept, nothing skipped or missing."""
    s = FrameStride(FPS)
    assert run(s, [0] * 100) == list(range(100))
    assert (s.stride, s.skipped, s.missing, s.most_stride) == (1, 0, 0, 1)


def test_stride_doubles_when_behind_and_halves_when_idle() -> None:
    """Half the queue waiting doubles the stride up to max_stride; an idle run halves it."""
    s = FrameStride(FPS, max_stride=4, queue_bound=10)
    kept = run(s, [5] * 40)
    assert s.stride == 4 and s.most_stride == 4
    assert kept[:2] == [0, 2] and all(k % 4 == 0 for k in kept[2:])
    assert s.skipped == 40 - len(kept)
    run(s, [0] * 40)
    assert s.stride == 1


def test_two_cameras_keep_the_same_instants() -> None:
    """Strides are powers of two keyed to the stamp: the slower camera's frames are a subset of
    the faster one's (the front camera 3 ms late, as in the render)."""
    fast, slow = FrameStride(FPS, max_stride=2), FrameStride(FPS, max_stride=8)
    backlog = [0] * 5 + [9] * 95
    kept_fast = set(run(fast, backlog))
    kept_slow = set(run(slow, backlog, offset_s=0.003))
    later = {k for k in kept_slow if k >= 10}
    assert later and later <= kept_fast


def test_missing_frames_are_counted_from_the_stamps() -> None:
    """Frames that never arrive (camera, network, best-effort middleware) are counted."""
    s = FrameStride(FPS)
    for k in (0, 1, 2, 5, 6, 10):
        s.keep(k / FPS, 0)
    assert s.missing == 2 + 3


@pytest.mark.parametrize('bad', [0, 3, 6])
def test_max_stride_must_be_a_power_of_two(bad: int) -> None:
    """A stride that is not a power of two would not align two cameras: one clear error."""
    with pytest.raises(ValueError, match=f'max_stride: must be a power of two >= 1, got {bad}'):
        FrameStride(FPS, max_stride=bad)
