"""The contact laws on both engines, grain by grain: a few grains started from one state on
dempath (``contact_forms: liggghts``, ``coulomb_limit: spring``) and on LIGGGHTS 3.8 follow the
same paths to rounding error, with SJKR cohesion, EPSD2 rolling resistance and Coulomb friction
together, for grains held by cohesion, a pair pulled apart and grains rolling on a cohesive floor.

A bed-scale difference between the engines (docs/liggghts.md) cannot be put down to the laws when
these agree. The grains start without spin: LIGGGHTS' ``run`` computes its set-up forces with the
rolling spring advanced by one step (epsd2 adds k_r omega dt before deciding not to store it), a
one-time torque dempath does not apply; with spin at the start the paths differ by about 1e-5 of
the spin for that reason alone.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from dempath.dumpio import read_dump
from dempath_sim.engine import Engine
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.walls import Plane
from dempath_sim.liggghts import commands as cmd
from dempath_sim.liggghts.fill_deck import write_data
from dempath_sim.liggghts.install import LiggghtsInstall
from dempath_sim.liggghts.runner import run_deck

R = 6e-3  # m: the reduced scene's coarse-grained top grains
DT = 1e-5  # s
STEPS, EVERY = 3000, 100
SAND = Material('sand', 1734.0, 1.7e6, 0.25)  # the paper's Table 6 sand
STEEL = Material('steel', 7800.0, 2.1e11, 0.30)
GRAINS = Interaction(0.3, 0.71, 0.71, 0.26, 1e5)  # cohesion at the library's upper strength


def _params(floor: Interaction | None = None) -> SimParams:
    materials = (SAND,) if floor is None else (SAND, STEEL)
    pairs = {(0, 0): GRAINS} if floor is None else {(0, 0): GRAINS, (0, 1): floor}
    return SimParams(materials=materials, interactions=pairs, dt=DT,
                     gravity=(0.0, 0.0, 0.0) if floor is None else (0.0, -9.81, 0.0),
                     contact_forms='liggghts', coulomb_limit='spring', skin=0.5)


def _dempath(params: SimParams, pos: NDArray[np.float64], vel: NDArray[np.float64],
             walls: list[Plane]) -> NDArray[np.float64]:
    """(frames, n, 9) positions, velocities and spins every EVERY steps, by id."""
    state = SimState.from_spheres(pos, np.full(len(pos), R), 0, params, velocities=vel)
    engine = Engine(params, walls)
    frames = [np.hstack([state.positions, state.velocities, state.angular_velocities])]
    for _ in range(STEPS // EVERY):
        state = engine.run(state, EVERY)
        order = np.argsort(state.ids)
        frames.append(np.hstack([state.positions, state.velocities,
                                 state.angular_velocities])[order])
    return np.array(frames)


def _liggghts(workdir: Path, install: LiggghtsInstall, params: SimParams,
              pos: NDArray[np.float64], vel: NDArray[np.float64],
              floor: bool) -> NDArray[np.float64]:
    """The same grains on LIGGGHTS: a deck from dempath's deck building blocks."""
    n = len(pos)
    write_data(str(workdir / 'grains.data'), np.arange(1, n + 1), pos, vel, np.zeros((n, 3)),
               np.full(n, R), SAND.density, len(params.materials),
               ((-0.1, -0.01, -0.1), (0.1, 0.1, 0.1)))
    digits = ' '.join(['%.17e'] * 9)
    lines = ['atom_style granular', 'atom_modify map array', 'boundary f f f', 'newton off',
             'communicate single vel yes', 'units si', 'soft_particles yes', 'hard_particles yes',
             'read_data grains.data', f'neighbor {cmd.fmt(0.5 * R)} bin', 'neigh_modify delay 0',
             *cmd.materials(params), *cmd.pair_style(params), *cmd.gravity(params),
             f'timestep {cmd.fmt(DT)}', 'fix integr all nve/sphere',
             *([cmd.plane_wall('floor', params, 'y', 0.0, 1)] if floor else []),
             f'dump d all custom {EVERY} grains.dump id x y z vx vy vz omegax omegay omegaz',
             f'dump_modify d sort id format "%d {digits}"', f'run {STEPS}']
    (workdir / 'in.grains').write_text('\n'.join(lines) + '\n')
    run_deck(workdir / 'in.grains', install=install)
    return np.array([frame.data[:, 1:] for frame in read_dump(workdir / 'grains.dump')])


def _same_paths(dem: NDArray[np.float64], lig: NDArray[np.float64]) -> None:
    assert dem.shape == lig.shape
    np.testing.assert_allclose(dem[..., :3], lig[..., :3], rtol=0, atol=1e-12)  # m
    speed = np.abs(lig[..., 3:6]).max()
    spin = np.abs(lig[..., 6:]).max()
    assert speed > 0.01 and spin > 0.1  # the grains move and turn
    np.testing.assert_allclose(dem[..., 3:6], lig[..., 3:6], rtol=0, atol=1e-9 * speed)
    np.testing.assert_allclose(dem[..., 6:], lig[..., 6:], rtol=0, atol=1e-9 * spin)


@pytest.mark.parametrize('pull', [0.03, 1.0])
def test_cohesive_grains_same_paths(tmp_path: Path, liggghts: LiggghtsInstall,
                                    pull: float) -> None:
    """Four grains, three of them touching; the second is pulled away at ``pull`` m/s:
    cohesion holds it at 0.03 m/s, at 1 m/s it tears free. Same paths either way."""
    params = _params()
    pos = np.array([[0.0, 0.0, 0.0], [2 * R - 3e-4, 0.0, 0.0], [R, 2 * R - 4e-4, 0.3 * R],
                    [-2 * R + 1e-4, 0.2 * R, 0.0]])
    vel = np.array([[0.0, 0.0, 0.0], [pull, 0.08, -0.02], [-0.05, 0.02, 0.04],
                    [-0.01, 0.0, 0.06]])
    dem = _dempath(params, pos, vel, [])
    _same_paths(dem, _liggghts(tmp_path, liggghts, params, pos, vel, floor=False))
    gap = np.linalg.norm(dem[-1, 1, :3] - dem[-1, 0, :3]) - 2 * R
    assert (gap < 0) if pull < 0.1 else (gap > 0.01)  # held, or torn free and 1-2 cm away


@pytest.mark.parametrize('floor_cohesion', [0.0, 2e4])
def test_grains_on_a_floor_same_paths(tmp_path: Path, liggghts: LiggghtsInstall,
                                      floor_cohesion: float) -> None:
    """Two grains sliding and rolling on a steel floor (with and without cohesion to it) and a
    third falling onto them, under gravity: same paths."""
    params = _params(Interaction(0.3, 0.4, 0.4, 0.26, floor_cohesion))
    pos = np.array([[0.0, R - 2e-4, 0.0], [2 * R - 3e-4, R - 1e-4, 0.0],
                    [R, 2.7 * R, 0.2 * R]])
    vel = np.array([[0.05, 0.0, 0.0], [0.2, 0.0, -0.1], [-0.05, -0.1, 0.04]])
    dem = _dempath(params, pos, vel, [Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 1)])
    _same_paths(dem, _liggghts(tmp_path, liggghts, params, pos, vel, floor=True))
