"""Per-camera detection streams and their pairing by timestamp.

Each camera's frames are detected on their own (a stream of ``(stamp_s, corners)``), so the two
recordings never need to be read in step. Frames are then paired by time: front stamp + offset
against side stamp, mutual nearest within a tolerance (``dempath.sync.sync_stamps``, the
workspace's one stamp synchroniser), the front corners interpolated to the side frame's
instant. The unknown offset itself is found by ``calibrator.estimate_offset``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from dempath.sync import sync_stamps

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
EXACT_S = 1e-3  # stamps closer than this are taken as simultaneous [s]


@dataclass
class DetectionStream:
    """One camera's detections, in arrival order.

    Attributes:
        n_corners: corners on the board.
        stamps: list of frame times [s].
        corners: list of (n_corners, 2) px arrays, NaN where unseen.
    """

    n_corners: int
    stamps: list[float] = field(default_factory=list)
    corners: list[FloatArray] = field(default_factory=list)

    def add(self, stamp_s: float, corners: FloatArray) -> None:
        """Append one frame's detection."""
        self.stamps.append(float(stamp_s))
        self.corners.append(np.asarray(corners, dtype=np.float64))

    def arrays(self) -> tuple[FloatArray, FloatArray]:
        """(n,) stamps [s] and (n, n_corners, 2) corners, sorted by time."""
        t = np.array(self.stamps, dtype=np.float64)
        c = np.array(self.corners).reshape(-1, self.n_corners, 2)
        order = np.argsort(t, kind='stable')
        return t[order], c[order]

    def __len__(self) -> int:
        return len(self.stamps)


def pair_frames(side: DetectionStream, front: DetectionStream, offset_s: float = 0.0,
                tol_s: float | None = None,
                interpolate: bool = True) -> tuple[FloatArray, FloatArray]:
    """Pair the two streams by time; unpaired frames are kept with NaN for the other camera.

    With ``interpolate``, a front frame that is not simultaneous with its side frame (stamps
    more than ``EXACT_S`` apart) is replaced by the linear interpolation, at the side frame's
    time, of the two front frames around it (NaN where either misses a corner): webcams and
    GoPros expose at their own instants, and the board moves in between.

    Args:
        side: side-camera detections.
        front: front-camera detections.
        offset_s: added to the front stamps to bring them onto the side camera's clock [s].
        tol_s: largest stamp difference of a pair [s]; half the smaller frame period by default.
        interpolate: interpolate the front corners to the side frame's time.

    Returns:
        ``(stamps (n,) s, corners (n, 2, n_corners, 2) px)``.
    """
    ts, cs = side.arrays()
    tf, cf = front.arrays()
    tf = tf + offset_s
    if tol_s is None:
        periods = [np.median(np.diff(t)) for t in (ts, tf) if len(t) > 1]
        tol_s = 0.5 * min(periods) if periods else 1e-3
    pairs, alone_s, alone_f = sync_stamps(ts, tf, tol_s, wait_for_nearest=True)
    pairs.sort()
    k = side.n_corners
    rows: list[tuple[float, FloatArray, FloatArray]] = []
    nan = np.full((k, 2), np.nan)
    if interpolate:
        rows += [(ts[i], cs[i], _front_at(ts[i], j, tf, cf)) for i, j in pairs]
    else:
        rows += [(ts[i], cs[i], cf[j]) for i, j in pairs]
    rows += [(ts[i], cs[i], nan) for i in sorted(alone_s)]
    rows += [(tf[j], nan, cf[j]) for j in sorted(alone_f)]
    rows.sort(key=lambda r: r[0])
    stamps = np.array([r[0] for r in rows])
    corners = np.array([np.stack([r[1], r[2]]) for r in rows]).reshape(-1, 2, k, 2)
    LOG.info('paired %d of %d side and %d front frames (offset %.3f s, tolerance %.3f s)',
             len(pairs), len(ts), len(tf), offset_s, tol_s)
    return stamps, corners


def _front_at(t: float, j: int, tf: FloatArray, cf: FloatArray) -> FloatArray:
    """Front corners at time ``t``: frame ``j`` if simultaneous, else interpolated."""
    if abs(tf[j] - t) <= EXACT_S or len(tf) < 2:
        return np.asarray(cf[j], np.float64)
    k = j if tf[j] <= t else j - 1
    if k < 0 or k + 1 >= len(tf):
        return np.full_like(cf[j], np.nan)
    period = float(np.median(np.diff(tf)))
    if tf[k + 1] - tf[k] > 1.5 * period:
        return np.full_like(cf[j], np.nan)
    a = (t - tf[k]) / (tf[k + 1] - tf[k])
    return np.asarray((1 - a) * cf[k] + a * cf[k + 1], np.float64)
