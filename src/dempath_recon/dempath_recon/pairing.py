"""The two cameras' pixel frames, and the matching of a synchronised pair by marker id.

The frames of the two cameras are paired by stamp in ``dempath.sync`` (the one stamp
synchroniser of the workspace: nearest stamp within ``slop_s``, frames without a partner counted).
Within a pair of frames, points are matched here by marker id; an id seen by only one camera, or
twice in one frame, is counted as rejected with its reason.
"""

from __future__ import annotations

from collections import Counter
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
