"""Bad set-ups stop with one clear error; particles leaving the domain are removed and counted."""

from __future__ import annotations

import logging
import re

import numpy as np
import pytest

from dempath_sim.engine import DEFAULT_MAX_OVERLAP_FRACTION, Engine, ToolPose
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.timestep import rayleigh_time_step
from dempath_sim.engine.walls import box_walls
from dempath_sim.errors import SimulationError

GRAIN = Material('grain', 2500.0, 1.0e7, 0.25)
STEEL = Material('steel', 7800.0, 2.1e11, 0.3)
INTER = Interaction(0.5, 0.5, 0.4)
RADIUS = 2.0e-3  # m


def _pair(params: SimParams, gap: float, speed: float = 0.0) -> SimState:
    pos = np.array([[0.0, 0.0, 0.0], [2.0 * RADIUS + gap, 0.0, 0.0]])
    vel = np.array([[speed, 0.0, 0.0], [-speed, 0.0, 0.0]])
    return SimState.from_spheres(pos, RADIUS, 0, params, velocities=vel)


def test_time_step_above_rayleigh_limit_names_stable_step() -> None:
    """dt above the Rayleigh limit raises SimulationError quoting the stable time step."""
    probe = SimParams((GRAIN,), {(0, 0): INTER})
    state = _pair(probe, 1e-3)
    dt_r = rayleigh_time_step(state.radii, state.material, probe)
    params = SimParams((GRAIN,), {(0, 0): INTER}, dt=3.0 * dt_r)
    with pytest.raises(SimulationError, match='stable dt') as info:
        Engine(params).step(state)
    assert f'{dt_r:.3e}' in str(info.value)


def test_excessive_overlap_is_reported() -> None:
    """Spheres overlapping by 40% of a radius (default limit 30%) stop the run naming both ids."""
    params = SimParams((GRAIN,), {(0, 0): INTER})
    assert params.max_overlap_fraction == DEFAULT_MAX_OVERLAP_FRACTION == 0.3
    with pytest.raises(SimulationError, match=r'overlap of 40\.0% .*particle 0 and particle 1'):
        Engine(params).step(_pair(params, -0.4 * RADIUS))


def test_energy_blow_up_is_reported() -> None:
    """A time step at the Rayleigh limit with a hard, deep contact blows up and is caught."""
    probe = SimParams((GRAIN,), {(0, 0): INTER})
    state = _pair(probe, -0.45 * RADIUS)
    dt_r = rayleigh_time_step(state.radii, state.material, probe)
    params = SimParams((GRAIN,), {(0, 0): Interaction(1.0, 0.0, 0.0)}, dt=dt_r,
                       gravity=(0.0, 0.0, 0.0), max_overlap_fraction=1.0)
    engine = Engine(params)
    with pytest.raises(SimulationError, match=r'energy blow-up.*stable dt'):
        engine.run(_pair(params, -0.45 * RADIUS), 200)


def test_particles_leaving_domain_are_removed_with_warning(
        caplog: pytest.LogCaptureFixture) -> None:
    """A particle crossing the domain box is removed, counted and logged; the others keep ids."""
    params = SimParams((GRAIN,), {(0, 0): INTER}, gravity=(0.0, 0.0, 0.0),
                       domain_min=(-0.01, -0.01, -0.01), domain_max=(0.01, 0.01, 0.01))
    pos = np.array([[0.0, 0.0, 0.0], [0.006, 0.0, 0.0], [0.0, 0.006, 0.0]])
    vel = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    state = SimState.from_spheres(pos, RADIUS, 0, params, velocities=vel, ids=[10, 11, 12])
    engine = Engine(params)
    with caplog.at_level(logging.WARNING, logger='dempath_sim.engine'):
        state = engine.run(state, int(0.01 / engine.time_step(state)))
    assert engine.removed_count == 1
    assert state.ids.tolist() == [10, 11]
    assert re.search(r'removed 1 particle.*ids \[12\]', caplog.text)
    np.testing.assert_allclose(state.positions[1], [0.006, 0.0, 0.0])


def test_missing_wall_interaction_names_the_pair() -> None:
    """A wall material without an interaction with the particles is named in the error."""
    params = SimParams((GRAIN, STEEL), {(0, 0): INTER})
    engine = Engine(params, walls=box_walls((-1, -1, -1), (1, 1, 1), material=1))
    with pytest.raises(SimulationError, match=r"no entry for materials \(0, 1\).*'steel'"):
        engine.step(_pair(params, 1e-3))


@pytest.mark.parametrize(('kwargs', 'field'), [
    ({'skin': -1.0}, 'skin'), ({'dt': 0.0}, 'dt'), ({'gravity': (0.0, float('nan'), 0.0)},
                                                    'gravity'),
    ({'domain_min': (1.0, 0.0, 0.0), 'domain_max': (0.0, 1.0, 1.0)}, 'domain_min'),
    ({'interactions': {(0, 3): INTER}}, 'interactions'),
])
def test_bad_params_name_the_field(kwargs: dict[str, object], field: str) -> None:
    """Invalid SimParams raise ValueError naming the field."""
    base: dict[str, object] = {'materials': (GRAIN,), 'interactions': {(0, 0): INTER}}
    base.update(kwargs)
    with pytest.raises(ValueError, match=f'SimParams.{field}'):
        SimParams(**base)  # type: ignore[arg-type]


@pytest.mark.parametrize(('make', 'field'), [
    (lambda: Material('x', -1.0, 1e7, 0.3), 'density'),
    (lambda: Material('x', 1000.0, 1e7, 0.6), 'poisson_ratio'),
    (lambda: Interaction(1.5, 0.5, 0.4), 'restitution'),
    (lambda: Interaction(0.5, 0.3, 0.4), 'dynamic_friction'),
])
def test_bad_materials_name_the_field(make: object, field: str) -> None:
    """Invalid Material / Interaction values raise ValueError naming the field."""
    with pytest.raises(ValueError, match=field):
        make()  # type: ignore[operator]


def test_non_finite_tool_pose_is_rejected() -> None:
    """A NaN tool pose is a SimulationError, not a silent NaN state."""
    with pytest.raises(SimulationError, match='ToolPose'):
        ToolPose(np.array([0.0, np.nan, 0.0]), np.zeros(3)).packed()
