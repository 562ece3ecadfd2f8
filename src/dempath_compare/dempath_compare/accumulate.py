"""Streaming collection of trajectories, one message (time step) at a time.

The compare node and the bag loader feed the same accumulator, so live topics and recorded bags
give identical tracks.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
from numpy.typing import NDArray

from dempath_compare.records import MEASURED, Track
from dempath_compare.runinfo import run_info


class TrajectoryAccumulator:
    """Collects samples per (group, id) in arrival order.

    Args:
        from_names: fill the tracks' tool speed and seed from their group names
            (``CompareConfig.identity_from_names``); off, they stay unknown (a bag or topic
            carries no run metadata).
    """

    def __init__(self, from_names: bool = False) -> None:
        self.from_names = from_names
        self._times: dict[tuple[str, int], list[float]] = defaultdict(list)
        self._points: dict[tuple[str, int], list[NDArray[np.float64]]] = defaultdict(list)
        self._markers: dict[tuple[str, int], int] = {}

    def __len__(self) -> int:
        return len(self._times)

    @property
    def n_samples(self) -> int:
        """Samples collected over all trajectories."""
        return sum(len(v) for v in self._times.values())

    def add_markers(self, group: str, t: float, marker_ids: NDArray[np.int64],
                    xyz: NDArray[np.float64]) -> None:
        """Add one measured time step: (n,) marker numbers, (n, 3) m positions at time t [s]."""
        self._add(group, t, marker_ids, marker_ids, xyz)

    def add_particles(self, run_id: str, t: float, ids: NDArray[np.int64],
                      marker_ids: NDArray[np.int64], xyz: NDArray[np.float64]) -> None:
        """Add one model time step: (n,) particle ids, (n,) marker ids (0: none), (n, 3) m."""
        self._add(run_id, t, ids, marker_ids, xyz)

    def _add(self, group: str, t: float, idents: NDArray[np.int64],
             marker_ids: NDArray[np.int64], xyz: NDArray[np.float64]) -> None:
        for ident, marker, point in zip(idents.tolist(), marker_ids.tolist(), xyz, strict=True):
            key = (group, int(ident))
            self._times[key].append(float(t))
            self._points[key].append(np.array(point, dtype=np.float64))
            self._markers[key] = int(marker)

    def tracks(self, kind: str) -> list[Track]:
        """The collected trajectories as tracks of ``kind`` (measured or model)."""
        out = []
        for key, times in self._times.items():
            group, ident = key
            label = f'{group}/marker{ident}' if kind == MEASURED else f'{group}/{ident}'
            out.append(Track(label, group, ident, self._markers[key], np.array(times),
                             np.array(self._points[key]).reshape(len(times), 3), '', '',
                             *run_info(group, from_names=self.from_names)))
        return out

    def clear(self) -> None:
        """Forget everything (a new run starts)."""
        self._times.clear()
        self._points.clear()
        self._markers.clear()
