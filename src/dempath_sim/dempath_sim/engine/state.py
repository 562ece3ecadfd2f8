"""The particle state record of the DEM engine.

`SimState` holds per-particle arrays whose shapes stay fixed between removals; the compiled
kernels update them in place. Particles may be removed (domain exit) and the engine then returns
a new, compacted `SimState`; `ids` are stable across removals, so outputs index by id.
Contact history (tangential and rolling springs) lives in the engine, not here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine.neighbors import permute_in_place
from dempath_sim.engine.params import SimParams

F64 = NDArray[np.float64]


@dataclass
class SimState:
    """Arrays of n spheres; float64 unless stated.

    Attributes:
        positions: (n, 3) centre positions [m] (X lateral, Y up, Z travel).
        velocities: (n, 3) translational velocities [m/s].
        angular_velocities: (n, 3) angular velocities [rad/s].
        radii: (n,) radii [m].
        masses: (n,) masses [kg].
        inertias: (n,) moments of inertia 2/5 m r^2 [kg m^2].
        material: (n,) int32 material index into SimParams.materials.
        ids: (n,) int64 stable particle ids.
        time: Simulated time [s].
        step: Number of steps taken.
        extra: Optional per-particle arrays (n, ...) carried through removals (e.g. roles).
    """

    positions: F64
    velocities: F64
    angular_velocities: F64
    radii: F64
    masses: F64
    inertias: F64
    material: NDArray[np.int32]
    ids: NDArray[np.int64]
    time: float = 0.0
    step: int = 0
    extra: dict[str, NDArray[np.generic]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        """Check shapes and finiteness; raise ValueError naming the field."""
        n = len(self.radii)
        for name in ('positions', 'velocities', 'angular_velocities'):
            arr = np.ascontiguousarray(getattr(self, name), dtype=np.float64)
            if arr.shape != (n, 3) or not np.isfinite(arr).all():
                msg = f'SimState.{name} must be a finite ({n}, 3) array, got shape {arr.shape}'
                raise ValueError(msg)
            setattr(self, name, arr)
        for name in ('radii', 'masses', 'inertias'):
            arr = np.ascontiguousarray(getattr(self, name), dtype=np.float64)
            if arr.shape != (n,) or not (arr > 0).all() or not np.isfinite(arr).all():
                msg = f'SimState.{name} must be a finite positive ({n},) array'
                raise ValueError(msg)
            setattr(self, name, arr)
        self.material = np.ascontiguousarray(self.material, dtype=np.int32)
        self.ids = np.ascontiguousarray(self.ids, dtype=np.int64)
        if self.material.shape != (n,) or self.ids.shape != (n,):
            msg = f'SimState.material and SimState.ids must have shape ({n},)'
            raise ValueError(msg)

    @property
    def n(self) -> int:
        """Number of particles."""
        return len(self.radii)

    @classmethod
    def from_spheres(cls, positions: F64, radii: F64, material: NDArray[np.integer] | int,
                     params: SimParams, velocities: F64 | None = None,
                     ids: NDArray[np.integer] | None = None) -> SimState:
        """Build a state from sphere centres and radii; masses from the material density.

        Args:
            positions: (n, 3) centres [m].
            radii: (n,) radii [m] (or a scalar broadcast to n).
            material: (n,) material indices or one index for all.
            params: Parameters giving the material densities.
            velocities: (n, 3) initial velocities [m/s]; zero if None.
            ids: (n,) stable ids; 0..n-1 if None.

        Returns:
            A state at time 0 with zero angular velocity.
        """
        pos = np.ascontiguousarray(positions, dtype=np.float64).reshape(-1, 3)
        n = len(pos)
        rad = np.broadcast_to(np.asarray(radii, dtype=np.float64), (n,)).copy()
        mat = np.broadcast_to(np.asarray(material, dtype=np.int32), (n,)).copy()
        if n and (mat.min() < 0 or mat.max() >= len(params.materials)):
            msg = f'SimState.material indices must be in [0, {len(params.materials)})'
            raise ValueError(msg)
        density = np.array([m.density for m in params.materials])[mat]
        masses = density * (4.0 / 3.0) * math.pi * rad ** 3
        vel = np.zeros((n, 3)) if velocities is None else np.array(velocities, dtype=np.float64)
        return cls(positions=pos.copy(), velocities=vel, angular_velocities=np.zeros((n, 3)),
                   radii=rad, masses=masses, inertias=0.4 * masses * rad ** 2, material=mat,
                   ids=np.arange(n, dtype=np.int64) if ids is None else np.asarray(ids))

    def kinetic_energy(self) -> float:
        """Translational plus rotational kinetic energy [J]."""
        trans = 0.5 * float(np.sum(self.masses * np.sum(self.velocities ** 2, axis=1)))
        rot = 0.5 * float(np.sum(self.inertias * np.sum(self.angular_velocities ** 2, axis=1)))
        return trans + rot

    def reorder(self, order: NDArray[np.int64], scratch: NDArray[np.uint8] | None = None) -> None:
        """Permute every per-particle array in place: row k becomes the old row order[k].

        Args:
            order: (n,) permutation of 0..n-1. ids and `extra` move with their particles.
            scratch: Optional reusable temporary of >= 24 n bytes (see `permute_in_place`).
        """
        for name in ('positions', 'velocities', 'angular_velocities', 'radii', 'masses',
                     'inertias', 'material', 'ids'):
            permute_in_place(getattr(self, name), order, scratch)
        for key, value in self.extra.items():
            self.extra[key] = value[order]

    def subset(self, keep: NDArray[np.bool_]) -> SimState:
        """Return a new state with only the particles where keep is True (same time, step)."""
        return SimState(self.positions[keep], self.velocities[keep],
                        self.angular_velocities[keep], self.radii[keep], self.masses[keep],
                        self.inertias[keep], self.material[keep], self.ids[keep],
                        self.time, self.step, {k: v[keep] for k, v in self.extra.items()})
