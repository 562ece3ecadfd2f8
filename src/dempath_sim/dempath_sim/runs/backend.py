"""One call shape for every simulation backend: ``backend.run(scene, options) -> SimResult``.

`Backend` is the protocol the native engine (`runs.native.NativeBackend`) and LIGGGHTS
(`dempath_sim.liggghts.LiggghtsBackend`) implement, so the CLI, the node, the cross-engine check
and the coming sweeps run either without knowing which. What is simulated is the `SceneSpec`;
how one run is carried out (cache, callbacks, cancellation) is `RunOptions`; settings that only
one backend has (LIGGGHTS' work directory, MPI processes) go to that backend's constructor.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from threading import Event
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from dempath_sim.runs.results import SimResult
from dempath_sim.scene import SceneSpec


@dataclass(frozen=True)
class Progress:
    """Progress of a run, passed to the progress callback.

    Attributes:
        phase: ``fill`` or ``drive``.
        sim_time_s: Simulated time of the phase so far [s].
        end_time_s: Simulated time at which the phase ends [s].
        wall_time_s: Wall-clock time of the phase so far [s].
    """

    phase: str
    sim_time_s: float
    end_time_s: float
    wall_time_s: float

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second (> 1: faster than real time)."""
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else 0.0


@dataclass(frozen=True)
class Frame:
    """One output frame for streaming consumers (the node).

    Attributes:
        t: Time since the tool started [s].
        ids, roles, marker_ids, radii: (n,) of the tracked particles.
        positions, velocities: (n, 3) [m], [m/s]; NaN when removed.
        tool_position, tool_velocity, tool_force, tool_torque: (3,) [m], [m/s], [N], [N m].
    """

    t: float
    ids: NDArray[np.int64]
    roles: NDArray[np.uint8]
    marker_ids: NDArray[np.int32]
    radii: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    tool_position: NDArray[np.float64]
    tool_velocity: NDArray[np.float64]
    tool_force: NDArray[np.float64]
    tool_torque: NDArray[np.float64]


@dataclass(frozen=True)
class RunOptions:
    """How to run (not what): cache, callbacks and cancellation.

    Attributes:
        cache_dir: Packing cache; the default cache if None.
        progress: Called with a Progress about every output interval.
        on_frame: Called with each output Frame (streaming consumers).
        stop: Set it to stop the run early: during the drive the result holds the frames so
            far; during the fill `RunStoppedError` is raised at the next settling check.
        follow_s: Time to go on recording after the tool has stopped at the end of its travel
            (the bed still moves) [s]; the tool stays where it stopped. Both backends.
        rest_tolerance_m: End the follow early once the bed is at rest to this bound [m]
            (``dempath_sim.runs.rest``; the frames left repeat the last state); 0: follow it
            all. The native backend only.
        shared_settle: Start the pass from the kept re-settled bed of its settle key when the
            cache holds one (``dempath_sim.runs.shared_settle``; `keep_settled` writes it);
            the same pass to the bit. The native backend only.
    """

    cache_dir: Path | None = None
    progress: Callable[[Progress], None] | None = None
    on_frame: Callable[[Frame], None] | None = None
    stop: Event | None = field(default=None, compare=False)
    follow_s: float = 0.0
    rest_tolerance_m: float = 0.0
    shared_settle: bool = False


class Backend(Protocol):
    """A simulation backend: runs a scene end to end and returns the tracked trajectories.

    Attributes:
        name: The engine's name (``'dempath'``, ``'liggghts'``).
    """

    name: str

    def run(self, scene: SceneSpec, options: RunOptions | None = None) -> SimResult:
        """Fill the bin (or reuse a packing), drive the tool and record; see the backend.

        Args:
            scene: What to simulate (effects applied through ``scene.physics_model()``).
            options: How to run; ``RunOptions()`` if None. A backend documents the options it
                cannot honour (LIGGGHTS runs as a subprocess: no frames, no early stop).

        Returns:
            The tracked particles, the tool pose, force and torque over time, and ``meta``.
        """
        ...


__all__ = ['Backend', 'Frame', 'Progress', 'RunOptions']
