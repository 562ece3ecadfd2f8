"""The kinematic pose of the tool that the engine moves: imposed position, velocity, rotation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dempath_sim.errors import SimulationError

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class ToolPose:
    """Kinematic pose of the tool frame in the world.

    Attributes:
        position: (3,) origin of the tool frame [m].
        velocity: (3,) velocity of that origin [m/s].
        rotation: (3, 3) rotation tool -> world; identity if None.
        angular_velocity: (3,) [rad/s] about the tool origin; zero if None.
    """

    position: F64
    velocity: F64
    rotation: F64 | None = None
    angular_velocity: F64 | None = None

    def packed(self) -> F64:
        """(18,) position, velocity, angular velocity, rotation row-major (kernel layout)."""
        rot = np.eye(3) if self.rotation is None else np.asarray(self.rotation, np.float64)
        omega = np.zeros(3) if self.angular_velocity is None else self.angular_velocity
        out = np.concatenate([np.asarray(self.position, np.float64).reshape(3),
                              np.asarray(self.velocity, np.float64).reshape(3),
                              np.asarray(omega, np.float64).reshape(3), rot.reshape(9)])
        if not np.isfinite(out).all():
            msg = f'ToolPose must be finite, got {self!r}'
            raise SimulationError(msg)
        return out
