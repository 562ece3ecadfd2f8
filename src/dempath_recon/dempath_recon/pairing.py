"""Approximate time synchronisation of the two cameras' pixel points, then pairing by marker id.

``message_filters`` is not available from PyPI, so the pairing lives here, in plain Python: a
frame of one camera is paired with the frame of the other camera whose stamp is nearest, if it
is within ``slop_s``. Frames are expected in stamp order per camera (as a player or a camera
driver delivers them); with both cameras at the same frame rate and ``slop_s`` under half the
frame period, the greedy nearest match is the only possible one. Frames that find no partner
are dropped and counted, never silently.

Within a pair of frames, points are matched by marker id; an id seen by only one camera, or twice
in one frame, is counted as rejected with its reason.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from dempath_recon.errors import PixelInputError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
SIDE, FRONT = 0, 1  # camera indices: Cam 1 (side), Cam 2 (front)


@dataclass(frozen=True)
class PixelFrame:
    """Pixel points of one camera image.

    Attributes:
        camera: SIDE (0) or FRONT (1).
        stamp_s: image stamp [s].
        ids: (m,) marker ids.
        uv: (m, 2) pixels [px].
    """

    camera: int
    stamp_s: float
    ids: IntArray
    uv: FloatArray

    def __post_init__(self) -> None:
        if self.camera not in (SIDE, FRONT):
            msg = f'camera: must be {SIDE} (side) or {FRONT} (front), got {self.camera!r}'
            raise PixelInputError(msg)
        ids = np.asarray(self.ids, dtype=np.int64).ravel()
        uv = np.asarray(self.uv, dtype=np.float64).reshape(-1, 2)
        if len(ids) != len(uv):
            msg = f'pixel frame: {len(ids)} marker ids but {len(uv)} points'
            raise PixelInputError(msg)
        object.__setattr__(self, 'ids', ids)
        object.__setattr__(self, 'uv', uv)


@dataclass(frozen=True)
class PairedFrame:
    """Both cameras' points of one instant, matched by marker id.

    Attributes:
        stamp_s: stamp of the pair [s] (the side camera's).
        dt_s: front stamp minus side stamp [s].
        ids: (k,) marker ids seen once by each camera.
        pixels: (k, 4) px = (xs, ys, xf, yf).
        rejected: reason -> count of points dropped while matching ids.
    """

    stamp_s: float
    dt_s: float
    ids: IntArray
    pixels: FloatArray
    rejected: dict[str, int] = field(default_factory=dict)


def match_ids(side: PixelFrame, front: PixelFrame) -> PairedFrame:
    """Match the points of two frames by marker id (ids seen twice in a frame are rejected)."""
    rejected: Counter[str] = Counter()
    keep = []
    for frame in (side, front):
        uniq, counts = np.unique(frame.ids, return_counts=True)
        dup = uniq[counts > 1]
        rejected['duplicate marker id'] += int(np.isin(frame.ids, dup).sum())
        keep.append(~np.isin(frame.ids, dup))
    ids_s, ids_f = side.ids[keep[0]], front.ids[keep[1]]
    common, i_s, i_f = np.intersect1d(ids_s, ids_f, return_indices=True)
    rejected['marker seen by one camera only'] += len(ids_s) + len(ids_f) - 2 * len(common)
    pixels = np.hstack([side.uv[keep[0]][i_s], front.uv[keep[1]][i_f]])
    return PairedFrame(side.stamp_s, front.stamp_s - side.stamp_s, common, pixels,
                       {k: v for k, v in rejected.items() if v})


class StampPairer:
    """Streaming pairing of the two cameras' frames by nearest stamp within ``slop_s``.

    Args:
        slop_s: largest stamp difference of a pair [s].
        queue_size: frames kept per camera while waiting for a partner.
    """

    def __init__(self, slop_s: float, queue_size: int = 16) -> None:
        if not slop_s >= 0.0:
            msg = f'slop_s: must be >= 0, got {slop_s!r}'
            raise ValueError(msg)
        if queue_size < 1:
            msg = f'queue_size: must be >= 1, got {queue_size!r}'
            raise ValueError(msg)
        self.slop_s = slop_s
        self.queues: tuple[deque[PixelFrame], deque[PixelFrame]] = (deque(), deque())
        self.queue_size = queue_size
        self.unpaired = 0  # frames dropped without a partner

    def update(self, frame: PixelFrame) -> list[PairedFrame]:
        """Add one frame; return the pair it completes (empty list when none yet)."""
        other = self.queues[1 - frame.camera]
        if other:
            gaps = [abs(f.stamp_s - frame.stamp_s) for f in other]
            best = int(np.argmin(gaps))
            if gaps[best] <= self.slop_s:
                partner = other[best]
                self.unpaired += best  # older frames of the other camera can no longer pair
                for _ in range(best + 1):
                    other.popleft()
                side, front = (frame, partner) if frame.camera == SIDE else (partner, frame)
                return [match_ids(side, front)]
        own = self.queues[frame.camera]
        own.append(frame)
        while other and other[0].stamp_s < frame.stamp_s - self.slop_s:
            other.popleft()  # too old to pair with this or any later frame of this camera
            self.unpaired += 1
        if len(own) > self.queue_size:
            own.popleft()
            self.unpaired += 1
        return []


def pair_frames(frames: Iterable[PixelFrame], slop_s: float,
                queue_size: int = 16) -> tuple[list[PairedFrame], int]:
    """Batch form of :class:`StampPairer`: frames in arrival order -> (pairs, unpaired count)."""
    pairer = StampPairer(slop_s, queue_size)
    pairs = [p for f in frames for p in pairer.update(f)]
    return pairs, pairer.unpaired + sum(len(q) for q in pairer.queues)
