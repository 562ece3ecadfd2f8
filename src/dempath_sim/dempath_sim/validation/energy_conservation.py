"""Energy conservation: elastic, frictionless spheres in a closed box, no gravity.

With restitution 1 and no friction the contact forces are conservative (Hertz:
U = 8/15 E* sqrt(R*) d^(5/2) per contact, Johnson 1985), so kinetic plus elastic energy must
stay constant; velocity Verlet keeps the drift small (< 1% over 10,000 steps is the bar).
The same set-up runs on dempath and, through a deck, on LIGGGHTS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath.dumpio import read_dump
from dempath_sim.engine import Interaction, SimParams, box_walls
from dempath_sim.engine.materials import pair_properties
from dempath_sim.liggghts import commands as cmd
from dempath_sim.validation import cases

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class EnergyCase(cases.SphereCase):
    """A gas of elastic spheres in a box (the spheres: see `SphereCase`).

    Attributes:
        n_side: Spheres per lattice edge (n_side^3 spheres).
        speed: Standard deviation of each initial velocity component [m/s].
        steps: Number of steps.
        seed: Seed of the initial velocities.
    """

    n_side: int = 6
    speed: float = 0.5
    steps: int = 10_000
    seed: int = 0

    @property
    def box(self) -> float:
        """Edge of the cubic box [m] (lattice spacing 2.6 radii)."""
        return self.n_side * 2.6 * self.radius

    def params(self) -> SimParams:
        """Sand particles (0) and steel walls (1), e = 1, no friction, no gravity."""
        return cases.case_params(self.material(), Interaction(1.0, 0.0, 0.0), walls=1,
                                 gravity=(0.0, 0.0, 0.0), max_overlap_fraction=0.5)

    def initial(self) -> tuple[F64, F64]:
        """Lattice positions (n, 3) [m] and Gaussian velocities (n, 3) [m/s], zero momentum."""
        a = self.box / self.n_side
        g = (np.arange(self.n_side) + 0.5) * a
        pos = np.stack(np.meshgrid(g, g, g, indexing='ij'), axis=-1).reshape(-1, 3)
        vel = np.random.default_rng(self.seed).normal(0.0, self.speed, pos.shape)
        return pos, vel - vel.mean(axis=0)


def total_energy(case: EnergyCase, pos: F64, vel: F64, omega: F64) -> float:
    """Kinetic (translation + rotation) plus Hertz elastic energy of spheres and walls [J]."""
    params = case.params()
    sand, steel = params.materials
    r = case.radius
    mass = sand.density * 4 / 3 * math.pi * r ** 3
    kin = 0.5 * mass * float(np.sum(vel ** 2)) + 0.5 * 0.4 * mass * r * r * float(
        np.sum(omega ** 2))
    from scipy.spatial import cKDTree

    e_pp = pair_properties(sand, sand).effective_youngs
    pairs = cKDTree(pos).query_pairs(2 * r, output_type='ndarray')
    d = 2 * r - np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1)
    elastic = float(np.sum(8 / 15 * e_pp * math.sqrt(r / 2) * np.clip(d, 0, None) ** 2.5))
    e_pw = pair_properties(sand, steel).effective_youngs
    dw = np.concatenate([r - pos, r - (case.box - pos)]).ravel()
    elastic += float(np.sum(8 / 15 * e_pw * math.sqrt(r) * np.clip(dw, 0, None) ** 2.5))
    return kin + elastic


@dataclass(frozen=True)
class EnergyResult:
    """Energy at start and end of the run: engine, e0 [J], e1 [J], steps, dt [s]."""

    engine: str
    e0: float
    e1: float
    steps: int
    dt: float

    @property
    def drift(self) -> float:
        """Relative energy change |e1 - e0| / e0 [-]."""
        return abs(self.e1 - self.e0) / self.e0


def energy_dempath(case: EnergyCase) -> EnergyResult:
    """Run the box on the dempath engine."""
    pos, vel = case.initial()
    walls = box_walls((0.0,) * 3, (case.box,) * 3, material=1, open_top=False)
    engine, state = cases.dempath_run(case.params(), pos, np.full(len(pos), case.radius),
                                      walls, velocities=vel)
    e0 = total_energy(case, state.positions, state.velocities, state.angular_velocities)
    state = engine.run(state, case.steps)
    e1 = total_energy(case, state.positions, state.velocities, state.angular_velocities)
    return EnergyResult('dempath', e0, e1, case.steps, float(engine.dt or 0.0))


def energy_liggghts(case: EnergyCase, workdir: Path, dt: float) -> EnergyResult:
    """Run the box on LIGGGHTS with time step ``dt`` [s] (use dempath's for a like run)."""
    params = case.params()
    pos, vel = case.initial()
    b = case.box
    lines = cases.liggghts_preamble(params, (0, 0, 0), (b, b, b), 0.5 * case.radius, dt)
    lines += [cmd.plane_wall(f'w{a}{k}', params, a, k * b, 1) for a in 'xyz' for k in (0, 1)]
    for k, (p, v) in enumerate(zip(pos, vel, strict=True)):
        lines += [f'create_atoms 1 single {cmd.fmt(p[0])} {cmd.fmt(p[1])} {cmd.fmt(p[2])} '
                  'units box', f'set atom {k + 1} vx {cmd.fmt(v[0])} vy {cmd.fmt(v[1])} '
                  f'vz {cmd.fmt(v[2])}']
    lines += [f'set group all diameter {cmd.fmt(2 * case.radius)} '
              f'density {cmd.fmt(case.density)}',
              'fix integr all nve/sphere',
              f'dump d all custom {case.steps} energy.dump id x y z vx vy vz omegax omegay '
              'omegaz', 'dump_modify d sort id', f'run {case.steps}']
    cases.run_liggghts(workdir, 'energy', lines)
    frames = read_dump(workdir / 'energy.dump')
    e = [total_energy(case, f.data[:, 1:4], f.data[:, 4:7], f.data[:, 7:10])
         for f in (frames[0], frames[-1])]
    return EnergyResult('liggghts', e[0], e[1], case.steps, dt)
