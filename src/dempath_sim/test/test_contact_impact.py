"""Two-sphere normal impact against Hertz theory: contact duration and restitution."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_sim.engine import Engine
from dempath_sim.engine.materials import Interaction, Material, pair_properties
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.timestep import hertz_contact_time

GLASS = Material('glass', 2500.0, 5.0e7, 0.25)
RADIUS = 2.0e-3  # m
STEPS_PER_CONTACT = 400  # time resolution of the measured contact


def _impact(speed: float, restitution: float) -> tuple[float, float, float]:
    """Collide two equal spheres head-on at relative speed `speed`.

    Returns:
        (measured contact duration [s], measured restitution [-], Hertz duration [s]).
    """
    m = GLASS.density * 4.0 / 3.0 * np.pi * RADIUS ** 3
    e_star = pair_properties(GLASS, GLASS).effective_youngs
    t_hertz = hertz_contact_time(m / 2.0, RADIUS / 2.0, e_star, speed)
    dt = t_hertz / STEPS_PER_CONTACT
    params = SimParams((GLASS,), {(0, 0): Interaction(restitution, 0.5, 0.4)},
                       gravity=(0.0, 0.0, 0.0), dt=dt, max_overlap_fraction=1.0)
    gap = 0.5 * speed * dt  # the spheres touch during the first step
    pos = np.array([[0.0, 0.0, 0.0], [2.0 * RADIUS + gap, 0.0, 0.0]])
    vel = np.array([[0.5 * speed, 0.0, 0.0], [-0.5 * speed, 0.0, 0.0]])
    state = SimState.from_spheres(pos, RADIUS, 0, params, velocities=vel)
    engine = Engine(params)
    in_contact = 0
    for _ in range(4 * STEPS_PER_CONTACT):
        state = engine.step(state)
        overlap = 2.0 * RADIUS - (state.positions[1, 0] - state.positions[0, 0])
        if overlap > 0:
            in_contact += 1
        elif in_contact:
            break
    rebound = (state.velocities[1, 0] - state.velocities[0, 0]) / speed
    return in_contact * dt, rebound, t_hertz


@pytest.mark.parametrize('speed', [0.05, 0.5, 2.0])
def test_elastic_contact_duration_matches_hertz(speed: float) -> None:
    """An elastic (e = 1) impact lasts the Hertz time 2.868 (m*^2/(R* E*^2 v))^(1/5) within 2%."""
    duration, rebound, t_hertz = _impact(speed, 1.0)
    assert duration == pytest.approx(t_hertz, rel=0.02)
    assert rebound == pytest.approx(1.0, rel=0.02)


@pytest.mark.parametrize('restitution', [0.3, 0.6, 0.9])
@pytest.mark.parametrize('speed', [0.05, 2.0])
def test_rebound_restitution_matches_setting(restitution: float, speed: float) -> None:
    """The rebound speed / impact speed equals the set restitution within 2% at any speed."""
    _, rebound, _ = _impact(speed, restitution)
    assert rebound == pytest.approx(restitution, rel=0.02)
