"""Effect scope: rolling resistance (like cohesion) can be limited to particle-particle contacts.

A LIGGGHTS deck that leaves ``rolling_friction`` off its wall fixes applies rolling resistance
between grains only; ``rolling_resistance.boundary_fraction: 0`` does the same in dempath.
"""

from __future__ import annotations

import numpy as np
import pytest

from dempath_sim.engine import Engine
from dempath_sim.engine.state import SimState
from dempath_sim.errors import SceneError
from dempath_sim.runs import WALLS, bin_walls, build_params
from dempath_sim.scene import bundled_scene

SPEED = 0.2  # m/s, the sphere's initial rolling speed along +Z


def test_scope_reaches_the_model_and_is_ranged() -> None:
    """boundary_fraction scales mu_r towards tool and walls; 1 (default) keeps every contact;
    a value outside [0, 1] is a scene error naming the key."""
    scene = bundled_scene('tiny')
    full = scene.physics_model()
    assert full.particle_wall.rolling_resistance == full.particle_particle.rolling_resistance
    scoped = scene.with_overrides({'rolling_resistance.boundary_fraction': 0.0}).physics_model()
    assert scoped.particle_particle.rolling_resistance == 0.26
    assert scoped.particle_wall.rolling_resistance == 0.0
    assert scoped.particle_tool.rolling_resistance == 0.0
    half = scene.with_overrides({'rolling_resistance.boundary_fraction': 0.5}).physics_model()
    assert half.particle_tool.rolling_resistance == pytest.approx(0.13)
    with pytest.raises((SceneError, ValueError), match='boundary_fraction'):
        scene.with_overrides({'rolling_resistance.boundary_fraction': 1.5}).physics_model()


def _roll(boundary_fraction: float, duration: float = 0.05) -> tuple[float, float]:
    """A 12 mm grain rolling without slip on the tiny bin's floor; returns its (speed, spin
    speed omega r) after ``duration`` [s] with the scene's rolling resistance scoped so."""
    scene = bundled_scene('tiny').with_overrides(
        {'rolling_resistance.boundary_fraction': boundary_fraction})
    params = build_params(scene, scene.physics_model())
    floor = [w for w in bin_walls(scene) if w.normal[1] > 0.5]
    assert floor and floor[0].material == WALLS
    r = 0.006
    y0 = float(floor[0].point[1]) + r
    state = SimState.from_spheres(np.array([[0.0, y0, 0.1]]), np.full(1, r), 0, params,
                                  velocities=np.array([[0.0, 0.0, SPEED]]))
    state.angular_velocities[0] = (SPEED / r, 0.0, 0.0)  # rolling on a floor along +Z
    engine = Engine(params, walls=floor)
    state = engine.run(state, int(duration / engine.time_step(state)))
    return float(state.velocities[0, 2]), float(state.angular_velocities[0, 0] * r)


def test_rolling_on_a_wall_feels_no_rolling_torque_when_scoped_to_particle_pairs() -> None:
    """With rolling resistance on every contact the grain slows down at about (5/7) mu_r g;
    scoped to particle pairs it rolls on at its speed (only the settling bounce is left)."""
    v_full, _ = _roll(1.0)
    v_pairs, spin_pairs = _roll(0.0)
    decel = 5.0 / 7.0 * 0.26 * 9.81 * 0.05  # m/s lost over 0.05 s at full mobilisation
    assert SPEED - v_full == pytest.approx(decel, rel=0.3)
    assert abs(SPEED - v_pairs) < 0.02 * decel
    assert spin_pairs == pytest.approx(v_pairs, rel=1e-2)  # rolling without slip (lever r - delta)
