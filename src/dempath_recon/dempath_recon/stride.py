"""Which live frames a detector that falls behind keeps: every frame, every 2nd, 4th, ... by stamp.

Two detectors (one per camera) that cannot keep up each lose frames; if each dropped whichever
frame happened to be oldest, the frames they keep would seldom be of the same instant, and the
reconstructor, which needs both views of an instant, would get few pairs (kept fraction p per
camera gives about p^2 pairs). A stride keyed to the frame's stamp aligns them without any
message between the detectors: frame number ``round(stamp * fps)`` is kept when it is a multiple
of the stride, and strides are powers of two, so every frame the slower detector keeps is also
kept by the faster one (pairs about p instead of p^2). The stride doubles when the work queue is
half full and halves after a run of kept frames that found the worker idle. It also counts the
frames that never arrived (gaps in the arriving stamps: lost by the camera, the network or the
middleware's best-effort queue). Plain module: the detector node feeds it every arriving frame and
publishes the counts.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class FrameStride:
    """Stamp-keyed frame decimation of one camera.

    Args:
        fps: nominal frame rate [1/s] (frame numbers are ``round(stamp_s * fps)``).
        max_stride: largest stride (a power of two; 1 turns decimation off).
        queue_bound: the worker's queue bound [frames]; half of it waiting doubles the stride.
        idle_to_halve: kept frames in a row that found the worker idle before the stride halves.
    """

    fps: float = 50.0
    max_stride: int = 8
    queue_bound: int = 10
    idle_to_halve: int = 4
    stride: int = 1
    skipped: int = 0  # frames not kept because of the stride
    missing: int = 0  # frames that never arrived (gaps in the arriving stamps)
    most_stride: int = 1
    _idle: int = 0
    _last: int | None = None  # frame number of the last arrival

    def __post_init__(self) -> None:
        if self.fps <= 0:
            raise ValueError(f'fps: must be > 0, got {self.fps!r}')
        if self.max_stride < 1 or self.max_stride & (self.max_stride - 1):
            raise ValueError(f'max_stride: must be a power of two >= 1, got {self.max_stride!r}')

    def keep(self, stamp_s: float, waiting: int) -> bool:
        """Whether to detect the frame stamped ``stamp_s`` given ``waiting`` frames (counts it).

        Args:
            stamp_s: the frame's stamp [s].
            waiting: frames waiting for the worker now (the one in hand included).
        """
        number = round(stamp_s * self.fps)
        if self._last is not None and number > self._last + 1:
            self.missing += number - self._last - 1
        self._last = number if self._last is None else max(number, self._last)
        if number % self.stride:
            self.skipped += 1
            return False
        if waiting >= max(2, self.queue_bound // 2) and self.stride < self.max_stride:
            self.stride *= 2
            self.most_stride = max(self.most_stride, self.stride)
            self._idle = 0
        elif waiting == 0:
            self._idle += 1
            if self._idle >= self.idle_to_halve and self.stride > 1:
                self.stride //= 2
                self._idle = 0
        else:
            self._idle = 0
        return True
