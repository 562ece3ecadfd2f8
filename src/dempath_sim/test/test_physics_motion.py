"""Single-sphere physics against analytic results: free fall and a sphere on an inclined plane."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dempath_sim.engine import Engine
from dempath_sim.engine.materials import Interaction, Material, pair_properties
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.walls import Plane

SAND = Material('sand', 2650.0, 1.0e8, 0.25)
G = 9.81  # m/s^2
RADIUS = 5.0e-3  # m


def test_free_fall_matches_analytic() -> None:
    """A sphere without contacts follows y0 + v0 t - g t^2 / 2 (velocity Verlet is exact)."""
    params = SimParams((SAND,), {(0, 0): Interaction(0.5, 0.5, 0.4)}, dt=1.0e-4)
    state = SimState.from_spheres(np.array([[0.0, 1.0, 0.0]]), RADIUS, 0, params,
                                  velocities=np.array([[0.1, 2.0, 0.0]]))
    state = Engine(params).run(state, 3000)
    t = state.time
    assert t == pytest.approx(0.3, rel=1e-12)
    expected = np.array([0.1 * t, 1.0 + 2.0 * t - 0.5 * G * t * t, 0.0])
    np.testing.assert_allclose(state.positions[0], expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(state.velocities[0], [0.1, 2.0 - G * t, 0.0], atol=1e-12)


def _slope_acceleration(angle_deg: float, inter: Interaction, duration: float = 0.06) -> float:
    """Down-slope acceleration [m/s^2] of a sphere released at rest on a slope (fit of v(t)
    over the second half of the run).

    The plane is y = 0 and gravity is tilted by the slope angle about Z, so down-slope is +X.
    The sphere starts at its static Hertz overlap, so the normal transient is small.
    """
    theta = math.radians(angle_deg)
    gravity = (G * math.sin(theta), -G * math.cos(theta), 0.0)
    params = SimParams((SAND,), {(0, 0): inter}, gravity=gravity)
    mass = SAND.density * 4.0 / 3.0 * math.pi * RADIUS ** 3
    e_star = pair_properties(SAND, SAND).effective_youngs
    delta = (3.0 * mass * G * math.cos(theta) / (4.0 * e_star * math.sqrt(RADIUS))) ** (2 / 3)
    state = SimState.from_spheres(np.array([[0.0, RADIUS - delta, 0.0]]), RADIUS, 0, params)
    engine = Engine(params, walls=[Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))])
    half = int(0.5 * duration / engine.time_step(state))
    state = engine.run(state, half)  # contact springs load up
    times: list[float] = []
    speeds: list[float] = []

    def record(st: SimState, _: Engine) -> None:
        times.append(st.time)
        speeds.append(float(st.velocities[0, 0]))

    engine.run(state, half, callback=record, callback_every=10)
    return float(np.polyfit(times, speeds, 1)[0])


def test_sphere_rolls_without_slip_below_friction_limit() -> None:
    """Below tan(theta) = 7/2 mu_s a free sphere rolls: a = 5/7 g sin(theta)."""
    acc = _slope_acceleration(20.0, Interaction(0.5, 0.5, 0.4))
    assert acc == pytest.approx(5.0 / 7.0 * G * math.sin(math.radians(20.0)), rel=0.02)


def test_sphere_slides_above_friction_limit() -> None:
    """Above tan(theta) = 7/2 mu_s it slides: a = g (sin(theta) - mu_d cos(theta))."""
    theta = math.radians(30.0)
    acc = _slope_acceleration(30.0, Interaction(0.5, 0.1, 0.08))
    assert acc == pytest.approx(G * (math.sin(theta) - 0.08 * math.cos(theta)), rel=0.02)


def _late_drift(angle_deg: float, inter: Interaction) -> float:
    """Down-slope distance travelled in the second half of a 0.08 s release [m]."""
    theta = math.radians(angle_deg)
    gravity = (G * math.sin(theta), -G * math.cos(theta), 0.0)
    params = SimParams((SAND,), {(0, 0): inter}, gravity=gravity)
    mass = SAND.density * 4.0 / 3.0 * math.pi * RADIUS ** 3
    e_star = pair_properties(SAND, SAND).effective_youngs
    delta = (3.0 * mass * G * math.cos(theta) / (4.0 * e_star * math.sqrt(RADIUS))) ** (2 / 3)
    state = SimState.from_spheres(np.array([[0.0, RADIUS - delta, 0.0]]), RADIUS, 0, params)
    engine = Engine(params, walls=[Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))])
    half = int(0.04 / engine.time_step(state))
    state = engine.run(state, half)
    x_half = float(state.positions[0, 0])
    state = engine.run(state, half)
    return float(state.positions[0, 0]) - x_half


@pytest.mark.parametrize(('angle_deg', 'moves'), [(20.0, False), (23.0, True)])
def test_sliding_onset_at_friction_coefficient(angle_deg: float, moves: bool) -> None:
    """With rolling blocked (mu_r = 5) a sphere holds while tan(theta) < mu = 0.4 (21.8 deg)
    and slides beyond."""
    drift = _late_drift(angle_deg, Interaction(0.5, 0.4, 0.4, rolling_resistance=5.0))
    assert (drift > 1e-4) == moves, f'drift {drift:.3e} m at {angle_deg} deg'


@pytest.mark.parametrize(('angle_deg', 'moves'), [(10.0, False), (12.5, True)])
def test_rolling_onset_at_rolling_resistance(angle_deg: float, moves: bool) -> None:
    """EPSD2 rolling resistance mu_r = 0.2 holds a sphere while tan(theta) < mu_r (11.3 deg)
    and lets it roll beyond."""
    drift = _late_drift(angle_deg, Interaction(0.5, 0.7, 0.6, rolling_resistance=0.2))
    assert (drift > 1e-4) == moves, f'drift {drift:.3e} m at {angle_deg} deg'


def test_rolling_with_resistance_matches_analytic() -> None:
    """Beyond the onset, a sphere rolls with a = 5/7 g (sin(theta) - mu_r cos(theta))."""
    theta = math.radians(16.0)
    acc = _slope_acceleration(16.0, Interaction(0.5, 0.7, 0.6, rolling_resistance=0.2))
    expected = 5.0 / 7.0 * G * (math.sin(theta) - 0.2 * math.cos(theta))
    assert acc == pytest.approx(expected, rel=0.03)
