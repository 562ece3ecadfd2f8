"""Conservation laws of the DEM engine: energy with e = 1, momentum without walls, dissipation."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_sim.engine import Engine
from dempath_sim.engine.energy import total_energy
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.walls import box_walls

GRAIN = Material('grain', 2500.0, 5.0e7, 0.25)
RADIUS = 2.0e-3  # m
BOX = ((0.0, 0.0, 0.0), (0.024, 0.024, 0.024))  # m


def _gas_in_box(rng: np.random.Generator, speed: float, params: SimParams) -> SimState:
    """27 spheres on a 3 x 3 x 3 lattice inside BOX with random velocities of size ~speed."""
    axis = np.array([0.006, 0.012, 0.018])
    pos = np.stack(np.meshgrid(axis, axis, axis, indexing='ij'), axis=-1).reshape(-1, 3)
    vel = rng.normal(scale=speed, size=pos.shape)
    return SimState.from_spheres(pos, RADIUS, 0, params, velocities=vel)


def test_energy_drift_below_one_percent_with_restitution_one() -> None:
    """Closed box, e = 1, no friction, with gravity: energy drifts < 1% over 10,000 steps."""
    params = SimParams((GRAIN,), {(0, 0): Interaction(1.0, 0.0, 0.0)})
    walls = box_walls(*BOX, open_top=False)
    state = _gas_in_box(np.random.default_rng(1), 0.3, params)
    engine = Engine(params, walls=walls)
    energies = [total_energy(state, params, walls)]
    contacts: list[int] = []
    for _ in range(20):
        state = engine.run(state, 500, callback=lambda _, e: contacts.append(e.n_contacts),
                           callback_every=10)
        energies.append(total_energy(state, params, walls))
    assert state.step == 10_000
    assert sum(contacts) > 10, 'the spheres must collide for the test to mean something'
    drift = np.abs(np.array(energies) / energies[0] - 1.0)
    assert drift.max() < 0.01, f'energy drift {drift.max():.2%}'


def test_momentum_conserved_without_walls_and_gravity() -> None:
    """A colliding cluster with friction, damping, rolling resistance and cohesion keeps its
    linear and angular momentum (no walls, no gravity)."""
    inter = Interaction(0.4, 0.6, 0.5, rolling_resistance=0.2, cohesion_energy_density=2.0e4)
    params = SimParams((GRAIN,), {(0, 0): inter}, gravity=(0.0, 0.0, 0.0),
                       max_overlap_fraction=0.2)
    rng = np.random.default_rng(2)
    axis = np.arange(4) * 5.5e-3
    pos = np.stack(np.meshgrid(axis, axis, axis[:3], indexing='ij'), axis=-1).reshape(-1, 3)
    pos += rng.uniform(-2e-4, 2e-4, size=pos.shape)
    centre = pos.mean(axis=0)
    state = SimState.from_spheres(pos, rng.uniform(1.5e-3, 2.5e-3, len(pos)), 0, params,
                                  velocities=-(pos - centre) * 20.0)
    state.angular_velocities[:] = rng.normal(scale=50.0, size=pos.shape)

    def momenta(st: SimState) -> tuple[np.ndarray, np.ndarray]:
        lin = (st.masses[:, None] * st.velocities).sum(axis=0)
        ang = (np.cross(st.positions, st.masses[:, None] * st.velocities)
               + st.inertias[:, None] * st.angular_velocities).sum(axis=0)
        return lin, ang

    lin0, ang0 = momenta(state)
    engine = Engine(params)
    state = engine.run(state, 3000)
    lin1, ang1 = momenta(state)
    scale_lin = float(np.sum(state.masses) * 0.2)
    scale_ang = scale_lin * 0.02
    np.testing.assert_allclose(lin1, lin0, atol=1e-9 * scale_lin)
    np.testing.assert_allclose(ang1, ang0, atol=1e-9 * scale_ang)
    assert engine.n_contacts > 0


@pytest.mark.parametrize('friction', [0.0, 0.5])
def test_energy_never_rises_with_damping(friction: float) -> None:
    """With e = 0.5 the total energy of a settling box never rises (beyond integration noise)."""
    params = SimParams((GRAIN,), {(0, 0): Interaction(0.5, friction, friction)})
    walls = box_walls(*BOX, open_top=False)
    state = _gas_in_box(np.random.default_rng(3), 0.3, params)
    engine = Engine(params, walls=walls)
    energies = [total_energy(state, params, walls)]
    for _ in range(60):
        state = engine.run(state, 50)
        energies.append(total_energy(state, params, walls))
    rises = np.diff(energies) / energies[0]
    assert rises.max() < 1e-4, f'energy rose by {rises.max():.2e} of E0'
    assert energies[-1] < 0.9 * energies[0]
