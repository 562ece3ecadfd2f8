"""Streaming comparison for the compare node: accumulate samples, score a run when it ends.

:class:`LiveComparer` is the node's core (no ROS): measured samples and model samples arrive one
time step at a time; :meth:`LiveComparer.finish` scores one model run against every measured
marker collected so far with the same pipeline as the offline tools (a test checks they agree).
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray

from dempath_compare.accumulate import TrajectoryAccumulator
from dempath_compare.config import CompareConfig
from dempath_compare.errors import CompareError
from dempath_compare.pipeline import compare_tracks
from dempath_compare.records import MEASURED, MODEL
from dempath_compare.scoring import CompareResult

log = logging.getLogger(__name__)


class LiveComparer:
    """Accumulates measured and model trajectories and scores model runs on demand.

    Args:
        config: comparison settings.
        experiment: group name given to the measured trajectories (e.g. ``experiment_1ms``).
    """

    def __init__(self, config: CompareConfig, experiment: str = 'experiment') -> None:
        self.config = config
        self.experiment = experiment
        self.measured = TrajectoryAccumulator(config.identity_from_names)
        self.model = TrajectoryAccumulator(config.identity_from_names)

    def add_markers(self, t: float, marker_ids: NDArray[np.int64],
                    xyz: NDArray[np.float64]) -> None:
        """One measured time step: (n,) marker numbers and (n, 3) m positions at t [s]."""
        self.measured.add_markers(self.experiment, t, marker_ids, xyz)

    def add_particles(self, run_id: str, t: float, ids: NDArray[np.int64],
                      marker_ids: NDArray[np.int64], xyz: NDArray[np.float64]) -> None:
        """One model time step of run ``run_id``."""
        self.model.add_particles(run_id, t, ids, marker_ids, xyz)

    def runs(self) -> list[str]:
        """Model runs with samples so far."""
        return sorted({t.group for t in self.model.tracks(MODEL)})

    def finish(self, run_id: str | None = None) -> CompareResult:
        """Score one model run (every run when None) against the measured markers.

        Raises:
            CompareError: nothing measured yet, or no samples of that run.
        """
        measured = self.measured.tracks(MEASURED)
        model = [t for t in self.model.tracks(MODEL) if run_id is None or t.group == run_id]
        if not measured:
            msg = 'no measured marker trajectories received yet'
            raise CompareError(msg)
        if not model:
            msg = f'run {run_id!r}: no model particle states received'
            raise CompareError(msg)
        result = compare_tracks(measured, model, self.config)
        log.info('scored run %s: %d pairs', run_id, int(result.scores.compared.sum()))
        return result
