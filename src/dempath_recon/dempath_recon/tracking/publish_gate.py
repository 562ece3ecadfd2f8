"""The publication gate: a numbered point whose 3D pair jumps away from its neighbours is withheld.

Every check before this one looks at one camera's pixels or at one pair's epipolar residual. A
pair can be consistent (both views see one marker) and still be the wrong marker: on faint or
crowded looks a number moves to the neighbour's spot in both views, and the published point then
lies a pitch away from where the marker is. The sand moves smoothly and markers that lie close
together move nearly together, so such a move shows as a 3D jump that the marker's neighbours do
not make.

:class:`PublicationGate` sees the frames as they are given out (both cameras, in order). For a
numbered point it takes the other camera's latest point with that number (within 1.5 frame
periods, moved to this frame's stamp by its 2D velocity) and triangulates the pair. The point is
withheld (its number taken off) when the pair reprojects more than ``residual_px`` off (one view
holds another marker), or when its 3D point lies more than ``gate_m`` from the marker's last
accepted 3D point moved by the median motion, over the same interval, of the markers that lay
within ``neighbour_m`` of it. The marker's history then stays at its last accepted point, so a
run of such pairs stays withheld; a run longer than ``reseed_s`` whose points follow each other
smoothly is the marker after all (near the tool a marker can move unlike its neighbours): the run
becomes its history and the pair goes out. A marker with no such neighbour is not predicted: its
own velocity can change at once (the tool strikes it), and a marker back from under the sand may
have moved anywhere the other checks allow. After ``stale_s`` without an accepted point the
history starts again. A marker's first pair, and a point whose other camera has no recent point
with its number, pass unchecked.

Measured on the tuning looks (session 17, track14): a wrong pair's first 3D point after a jump
lies 16-21 mm off this prediction, a right one's 99th percentile 7 mm (all within 12.3 mm). Wrong
stretches that start with the marker's first pair, or last longer than ``reseed_s``, are not
caught. Live, where a tracker gives out one camera's frames only, the gate sees no pairs and
passes everything.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera, reprojection_errors
from dempath_recon.tracking.associate import triangulate_pairs
from dempath_recon.tracking.records import PixelFrame

FloatArray = NDArray[np.float64]
UNNUMBERED = -1


def _length(v: FloatArray) -> float:
    """Euclidean length of a vector (3,), as ``np.linalg.norm`` computes it, without its
    checks (called for every neighbour of every checked point)."""
    return math.sqrt(float(v.dot(v)))


def _median_rows(rows: list[FloatArray]) -> FloatArray:
    """(3,) the median of vectors (3,) over the list, as ``np.median(axis=0)`` gives it (the
    mean of the middle two of an even count), by one sort (``np.median`` cost 25 us a call,
    several calls a frame)."""
    a = np.sort(np.array(rows), axis=0)
    half = len(a) // 2
    return np.asarray(a[half] if len(a) % 2 else (a[half - 1] + a[half]) / 2, np.float64)


class GateConfig(NamedTuple):
    """Settings of the publication gate.

    Attributes:
        gate_m: largest distance of a pair's 3D point from the marker's predicted one [m]
            (0.6 of the 25 mm pitch of the tiny scene's grid; on the tuning looks right pairs lay
            99 % within 7 mm, all within 12.3, wrong pairs' first points 16-21 mm off; a marker
            the tool lifts while its neighbour stays: 12.2 mm).
        neighbour_m: markers this near the marker's last accepted point give the motion [m].
        stale_s: a marker's history older than this is dropped [s].
        reseed_s: a smooth run of withheld pairs spanning more than this becomes the marker's
            history [s].
        residual_px: a pair whose linear triangulation reprojects farther than this from
            either view is withheld [px] (a number given to another marker's spot in one view
            only; the pair checks withhold at 3 x ``StereoTrackConfig.epipolar_px``).
    """

    gate_m: float = 0.015
    neighbour_m: float = 0.040
    stale_s: float = 0.5
    reseed_s: float = 0.05
    residual_px: float = 6.0


class _History:
    """A marker's accepted 3D points, oldest first (stamps ascending)."""

    __slots__ = ('_asked', 'times', 'xyz')

    def __init__(self) -> None:
        self.times: list[float] = []
        self.xyz: list[FloatArray] = []
        # answers of ``near`` since the last change: every check of a frame asks each
        # neighbour's point at the same two stamps (two thirds of the gate's time, session 24)
        self._asked: dict[tuple[float, float], FloatArray | None] = {}

    def add(self, stamp_s: float, xyz: FloatArray, keep_s: float) -> None:
        """Append a point and drop those older than ``keep_s`` before it."""
        self._asked.clear()
        self.times.append(stamp_s)
        self.xyz.append(xyz)
        cut = bisect_left(self.times, stamp_s - keep_s)
        if cut:
            del self.times[:cut], self.xyz[:cut]

    def near(self, stamp_s: float, within_s: float) -> FloatArray | None:
        """The accepted point nearest ``stamp_s`` within ``within_s``, or None."""
        key = (stamp_s, within_s)
        if key in self._asked:
            return self._asked[key]
        k = bisect_left(self.times, stamp_s)
        best, gap = None, within_s
        for j in (k - 1, k):
            if 0 <= j < len(self.times) and abs(self.times[j] - stamp_s) <= gap:
                best, gap = self.xyz[j], abs(self.times[j] - stamp_s)
        self._asked[key] = best
        return best


class PublicationGate:
    """Withholds numbered points whose pair's 3D point jumps away from the marker's neighbours.

    Args:
        cameras: ``{name: camera}``, the two calibrated cameras.
        fps: nominal frame rate [1/s].
        config: the gate's settings.
    """

    def __init__(self, cameras: Mapping[str, Camera], fps: float,
                 config: GateConfig | None = None) -> None:
        self.cameras = dict(cameras)
        self.period_s = 1.0 / fps
        self.config = config or GateConfig()
        # each camera's last two numbered points per marker, as given to the gate: (t, uv,
        # whether it went out)
        self._seen: dict[str, dict[int, list[tuple[float, FloatArray, bool]]]] = {
            c: {} for c in self.cameras}
        self._accepted: dict[int, _History] = {}
        self._pending: dict[int, list[tuple[float, FloatArray]]] = {}  # withheld run per marker
        self.withheld = 0

    def check(self, frame: PixelFrame) -> tuple[PixelFrame, list[int]]:
        """``frame`` with its numbered points that fail the gate unnumbered, and their numbers.

        Frames must come in the order they are given out (both cameras)."""
        numbered = np.flatnonzero(frame.markers >= 0)
        if len(self.cameras) != 2 or frame.camera not in self.cameras or not len(numbered):
            return frame, []
        other = next(c for c in self.cameras if c != frame.camera)
        t = frame.stamp_s
        ks, own, partner = [], [], []
        for k in numbered.tolist():
            uv_o = self._partner(other, int(frame.markers[k]), t)
            if uv_o is not None:
                ks.append(k)
                own.append(frame.uv[k])
                partner.append(uv_o)
        withheld: list[int] = []
        markers = frame.markers
        if ks:
            views = np.stack([np.array(own, np.float64), np.array(partner, np.float64)])
            pair = [self.cameras[frame.camera], self.cameras[other]]
            # the linear triangulation of ``triangulate_points(refine=False)``, two views
            xyz, _ = triangulate_pairs(pair[0], pair[1], views[0], views[1])
            for k, x, res in zip(ks, xyz, reprojection_errors(pair, views, xyz), strict=True):
                m = int(frame.markers[k])
                if not np.isfinite(x).all():
                    continue
                if res > self.config.residual_px or not self._agrees(m, t, x):
                    withheld.append(m)
        if withheld:
            markers = np.where(np.isin(frame.markers, withheld), UNNUMBERED,
                               frame.markers).astype(np.int32)
            self.withheld += len(withheld)
        seen = self._seen[frame.camera]
        for k in numbered.tolist():  # withheld ones too: the other camera's pairs check them
            m = int(frame.markers[k])
            rows = seen.setdefault(m, [])
            rows.append((t, np.asarray(frame.uv[k], np.float64), m not in withheld))
            del rows[:-2]
        return frame._replace(markers=markers), withheld

    def _partner(self, camera: str, marker: int, stamp_s: float) -> FloatArray | None:
        """``camera``'s latest point of ``marker`` moved to ``stamp_s`` by its 2D velocity
        (between two points that both went out; None: none within 1.5 frame periods)."""
        rows = self._seen[camera].get(marker)
        if not rows or abs(stamp_s - rows[-1][0]) > 1.5 * self.period_s:
            return None
        t1, uv1, out1 = rows[-1]
        if len(rows) == 2 and out1 and rows[0][2] and 0 < t1 - rows[0][0] <= 1.5 * self.period_s:
            return uv1 + (uv1 - rows[0][1]) * (stamp_s - t1) / (t1 - rows[0][0])
        return uv1

    def _agrees(self, marker: int, stamp_s: float, xyz: FloatArray) -> bool:
        """Whether ``xyz`` lies within the gate of the marker's prediction; an agreeing (or
        first, or after a stale history) point is accepted into the history."""
        cfg = self.config
        hist = self._accepted.get(marker)
        if hist is None or not hist.times or stamp_s - hist.times[-1] > cfg.stale_s:
            hist = self._accepted[marker] = _History()
        else:
            t1, x1 = hist.times[-1], hist.xyz[-1]
            moves = []
            for n, h in self._accepted.items():
                if n == marker or not h.times:
                    continue
                then = h.near(t1, self.period_s)
                now = h.near(stamp_s, self.period_s)
                if then is not None and now is not None \
                        and _length(then - x1) < cfg.neighbour_m:
                    moves.append(now - then)
            # no neighbour to say how it should have moved: it goes out
            if moves and _length(xyz - x1 - _median_rows(moves)) > cfg.gate_m \
                    and not self._reseed(marker, stamp_s, xyz):
                return False
            hist = self._accepted[marker]
        self._pending.pop(marker, None)
        hist.add(stamp_s, xyz, cfg.stale_s + 2 * self.period_s)
        return True

    def _reseed(self, marker: int, stamp_s: float, xyz: FloatArray) -> bool:
        """Note a withheld pair; True (its run now the marker's history) when the run of
        withheld pairs spans more than ``reseed_s`` and each lies within the gate of the one
        before (a marker moving unlike its neighbours, not a jump to another marker)."""
        run = self._pending.setdefault(marker, [])
        if run and np.linalg.norm(xyz - run[-1][1]) > self.config.gate_m:
            run.clear()
        run.append((stamp_s, xyz))
        if stamp_s - run[0][0] <= self.config.reseed_s:
            return False
        hist = self._accepted[marker] = _History()
        for t, x in run[:-1]:
            hist.add(t, x, self.config.stale_s + 2 * self.period_s)
        return True
