"""The set-up every validation case shares: its materials, its parameters, and one run on each
engine from the same records.

Each case (``impact``, ``incline``, ``energy``, ``repose``) states what it simulates as one
`SimParams` built by :func:`case_params` (sand particles, material 0, and steel bodies 1, 2, ...)
and its spheres (`SphereCase`); :func:`dempath_run` turns that into an engine and a state, and
:func:`liggghts_preamble` and :func:`run_liggghts` into a LIGGGHTS 3.8 deck (atom style, box,
materials, contact model, gravity, time step) that runs in the case's work directory. Both
engines therefore take the coefficients from the same record.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine import (
    Engine,
    Interaction,
    Material,
    Plane,
    SimParams,
    SimState,
    TriangleMesh,
)
from dempath_sim.liggghts import commands as cmd
from dempath_sim.liggghts.runner import run_deck

SAND_YOUNGS_PA = 1.7e6  # the paper's particle Young's modulus (Table 6) [Pa]
SAND_POISSON = 0.25  # the paper's particle Poisson's ratio (Table 6) [-]
STEEL = Material('steel', 7800.0, 2.1e11, 0.3)  # walls, base, tube (Table 2 of the paper)
FLOOR = Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 1)  # the plane y = 0, material 1 (steel)


def sand(density: float = 2650.0, youngs: float = SAND_YOUNGS_PA,
         poisson: float = SAND_POISSON) -> Material:
    """Sand grains: density [kg/m^3] (2650 quartz, 1734 the scenes'), modulus [Pa], nu [-]."""
    return Material('sand', density, youngs, poisson)


@dataclass(frozen=True, kw_only=True)
class SphereCase:
    """The sand spheres a case runs (keyword-only fields after the case's own).

    Attributes:
        radius: Sphere radius [m].
        density: Solid density [kg/m^3] (quartz).
        youngs: Young's modulus [Pa] (the paper's Table 6).
        poisson: Poisson's ratio [-].
    """

    radius: float = 0.002
    density: float = 2650.0
    youngs: float = SAND_YOUNGS_PA
    poisson: float = SAND_POISSON

    def material(self) -> Material:
        """The spheres' material (material 0 of the case's parameters)."""
        return sand(self.density, self.youngs, self.poisson)


def case_params(particles: Material, particle_pair: Interaction,
                wall_pair: Interaction | None = None, walls: int = 0,
                **settings: Any) -> SimParams:
    """Parameters of a case: ``particles`` (material 0) and ``walls`` steel bodies (1..walls).

    Args:
        particles: The particles' material.
        particle_pair: Particle-particle interaction.
        wall_pair: Particle-wall interaction of every steel body (``particle_pair`` if None).
        walls: Number of steel bodies (planes, tube) after the particles.
        **settings: Other `SimParams` fields (gravity, dt, domain, max_overlap_fraction).
    """
    pair = particle_pair if wall_pair is None else wall_pair
    interactions = {(0, 0): particle_pair, **{(0, k): pair for k in range(1, walls + 1)}}
    return SimParams(materials=(particles, *(STEEL,) * walls), interactions=interactions,
                     **settings)


def dempath_run(params: SimParams, positions: NDArray[np.float64], radii: NDArray[np.float64],
                walls: Sequence[Plane] = (), tool: TriangleMesh | None = None,
                velocities: NDArray[np.float64] | None = None) -> tuple[Engine, SimState]:
    """The engine and the state of a case on dempath: spheres of material 0.

    Args:
        params: The case's parameters.
        positions: (n, 3) centres [m].
        radii: (n,) radii [m].
        walls: Planes of the case.
        tool: A kinematic mesh (the repose tube), if any.
        velocities: (n, 3) initial velocities [m/s]; at rest if None.
    """
    state = SimState.from_spheres(positions, radii, 0, params, velocities=velocities)
    return Engine(params, walls, tool), state


def liggghts_preamble(params: SimParams, box_min: Sequence[float], box_max: Sequence[float],
                      skin_m: float, dt: float, friction: str = 'static',
                      hard: bool = True) -> list[str]:
    """Deck lines up to the time step: header, materials, contact model, gravity, timestep.

    Args:
        params: The case's parameters (one atom type per material).
        box_min, box_max: (3,) corners of the simulation box [m].
        skin_m: Neighbour skin [m].
        dt: Time step [s].
        friction: Which dempath coefficient LIGGGHTS uses ('static' or 'dynamic').
        hard: Whether to allow LIGGGHTS' stiff materials (``hard_particles yes``, for steel).
    """
    lines = cmd.header(box_min, box_max, len(params.materials), skin_m, cmd.needs_soft(params))
    if hard:
        lines.append('hard_particles yes')
    return [*lines, *cmd.materials(params, friction), *cmd.pair_style(params),
            *cmd.gravity(params), f'timestep {cmd.fmt(dt)}']


def run_liggghts(workdir: Path, name: str, lines: Sequence[str], nprocs: int = 1) -> Path:
    """Write ``workdir/in.<name>`` from ``lines`` and run it; returns ``workdir``.

    Raises:
        LiggghtsNotFoundError: LIGGGHTS or mpirun missing.
        LiggghtsRunError: The run failed (names the log).
    """
    workdir.mkdir(parents=True, exist_ok=True)
    deck = workdir / f'in.{name}'
    deck.write_text('\n'.join(lines) + '\n')
    run_deck(deck, nprocs=nprocs)
    return workdir
