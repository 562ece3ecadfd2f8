"""Ending a run's follow once its bed is at rest (issue 30: runs that stop when the markers'
statistics stop changing).

After the tool has stopped, a run is followed for ``follow_s`` so that the bed's late motion
(the furrow's walls slumping, heaps running down) is in the record. Once every particle has
stopped, the frames left would only repeat the last one: :class:`RestWatch` says when that is
so, and the run then writes the frames left from its last state without stepping.

The rule (physics, not a tuned figure): after the tool has stopped, the largest displacement of
any particle over the last frame, times the frames still to record, is an upper bound of how far
any particle can still move if the bed keeps decelerating (a bed the tool no longer drives only
loses kinetic energy to its damped contacts). The run ends when that bound is at most
``tolerance_m`` for ``REST_FRAMES`` frames in a row (one quiet frame can be the turning point of
a slow rocking motion). Every recorded position is then within ``tolerance_m`` of the one the
full run would record, so every window-mean displacement the diagnosis reads moves by less than
that. The default, ``REST_TOLERANCE_M`` = 0.05 mm, is half the packed library's displacement
quantum (``dempath_diagnose.library.packed.QUANTUM_M``) and 1/30 of a camera pair's 1.5 mm
noise per axis. A bed that a later avalanche sets moving again after three quiet frames is the
case the rule would miss; with the tool standing still nothing drives one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

REST_TOLERANCE_M = 5e-5  # bound on any particle's remaining motion when a run ends early [m]
REST_FRAMES = 3  # consecutive frames the bound must hold


@dataclass
class RestWatch:
    """Watches the frames after the tool has stopped; `at_rest` says when to end the run.

    Attributes:
        tolerance_m: Bound on any particle's remaining displacement [m] (> 0).
        frames_needed: Consecutive frames the bound must hold.
        quiet: Consecutive frames it has held so far.
        last_step_m: Largest displacement over the last frame [m] (inf before two frames).
    """

    tolerance_m: float
    frames_needed: int = REST_FRAMES
    quiet: int = 0
    last_step_m: float = float('inf')
    _ids: NDArray[np.int64] | None = field(default=None, repr=False)
    _positions: NDArray[np.float64] | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if not self.tolerance_m > 0.0 or self.frames_needed < 1:
            msg = (f'RestWatch: tolerance_m must be > 0 and frames_needed >= 1, got '
                   f'{self.tolerance_m!r} and {self.frames_needed!r}')
            raise ValueError(msg)

    def at_rest(self, ids: NDArray[np.int64], positions: NDArray[np.float64],
                frames_left: int) -> bool:
        """Take the frame (particle ids, positions [m]) and say whether the run may end here.

        Particles are matched by id (the engine reorders them and removes those that leave the
        domain); a frame whose particles are not the last frame's restarts the count.
        """
        order = np.argsort(ids, kind='stable')
        ids_sorted, pos = ids[order], positions[order]
        if self._ids is None or self._positions is None or not np.array_equal(ids_sorted,
                                                                             self._ids):
            self.quiet, self.last_step_m = 0, float('inf')
        else:
            step = np.sqrt(((pos - self._positions) ** 2).sum(axis=1))
            self.last_step_m = float(np.nanmax(step, initial=0.0))
            bound = self.last_step_m * max(frames_left, 1)
            self.quiet = self.quiet + 1 if bound <= self.tolerance_m else 0
        self._ids, self._positions = ids_sorted, pos.copy()
        return self.quiet >= self.frames_needed


__all__ = ['REST_FRAMES', 'REST_TOLERANCE_M', 'RestWatch']
