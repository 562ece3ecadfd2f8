"""How long a particle pair's springs live: reset at separation (dempath's forms) or kept until the
next neighbour-list build (LIGGGHTS 3.8's, ``contact_forms: liggghts``), and what a pair that
touches again starts from."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_sim.engine import Engine, ToolPose, TriangleMesh
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.validation.deck_setup import DECK_DIR

R = 2e-3  # m
DT = 1e-5  # s


def _pair(forms: str, mu: float = 0.5) -> tuple[Engine, SimState]:
    """Two touching grains, no gravity: the second slides past the first (+Y) and moves away
    (+X) so that the pair separates after a few steps with a loaded spring."""
    params = SimParams(materials=(Material('sand', 1500.0, 1e6, 0.25),),
                       interactions={(0, 0): Interaction(0.5, mu, mu)}, gravity=(0, 0, 0),
                       dt=DT, contact_forms=forms, coulomb_limit='spring', skin=1.0)
    state = SimState.from_spheres(np.array([[0.0, 0.0, 0.0], [2 * R - 2e-6, 0.0, 0.0]]),
                                  np.full(2, R), 0, params,
                                  velocities=np.array([[0.0, 0.0, 0.0], [0.05, 0.02, 0.0]]))
    engine = Engine(params)
    engine.bind(state)
    return engine, state


def _gap(state: SimState) -> float:
    return float(np.linalg.norm(state.positions[1] - state.positions[0]) - 2 * R)


@pytest.mark.parametrize('forms', ['dempath', 'liggghts'])
def test_springs_after_separation(forms: str) -> None:
    """Touching for a few steps loads the spring; once apart, dempath's forms reset it and
    LIGGGHTS' keep it (unchanged) until a list build, which drops it."""
    engine, state = _pair(forms)
    state = engine.step(state)
    assert _gap(state) < 0 and engine.loaded_springs == 1
    n = 0
    while _gap(state) < 0:
        state = engine.step(state)
        n += 1
        assert n < 100
    state = engine.step(state)  # one step apart: the force pass sees the pair separated
    assert _gap(state) > 0
    assert engine.loaded_springs == (1 if forms == 'liggghts' else 0)
    engine.find_contacts(state, np.arange(state.n))  # a list build, the pair still listed
    assert engine.loaded_springs == 0


def test_liggghts_pair_touching_again_resumes_its_spring() -> None:
    """A pair that parts and touches again before a list build starts from its old spring:
    after one step of contact the spring is the old one plus v_t dt (minus its part along the
    normal), not v_t dt alone as for a new contact."""
    engine, state = _pair('liggghts', mu=5.0)  # sticking throughout: no Coulomb cut
    while True:
        state = engine.step(state)
        if _gap(state) > 0:
            break
    old = engine.pair_springs[0][0].copy()  # the kept spring
    assert np.linalg.norm(old) > 0
    state.velocities[1] = [-0.05, -0.01, 0.0]  # back towards the first grain
    while _gap(state) > 0:
        state = engine.step(state)
    # The first step of the new contact: xi = (old projected on the tangent plane) + v_t dt.
    d = state.positions[0] - state.positions[1]
    n = d / np.linalg.norm(d)  # normal from grain 1 to grain 0 (the pair's i = 0)
    v = state.velocities[0] - state.velocities[1]  # no spin yet: relative contact velocity
    vt = v - (v @ n) * n
    want = old - (old @ n) * n + vt * DT
    # The velocities were kicked once by the new force after the spring update: compare to
    # the tolerance of that kick.
    spring = engine.pair_springs[0][0]
    np.testing.assert_allclose(spring, want, rtol=0.05, atol=1e-12)
    assert abs(np.linalg.norm(spring) - np.linalg.norm(vt * DT)) > 0.5 * np.linalg.norm(old)


@pytest.mark.parametrize('forms', ['dempath', 'liggghts'])
def test_moving_tool_triggers_list_builds(forms: str) -> None:
    """With LIGGGHTS' forms a list build follows every half skin of tool travel (one step
    late, as LIGGGHTS 3.8 decides it); with dempath's forms the resting grains need none."""
    params = SimParams(materials=(Material('sand', 1500.0, 1e6, 0.25),
                                  Material('steel', 7800.0, 2e11, 0.3)),
                       interactions={(0, 0): Interaction(0.5, 0.5, 0.5),
                                     (0, 1): Interaction(0.5, 0.4, 0.4)},
                       gravity=(0, 0, 0), dt=DT, contact_forms=forms, skin=0.5)
    tine = TriangleMesh.from_stl(DECK_DIR / 'tine.stl', material=1)
    state = SimState.from_spheres(np.array([[0.5, 0.0, 0.0]]), np.full(1, R), 0, params)
    engine = Engine(params, (), tine)
    v = np.array([0.0, 0.0, 1.0])
    engine.tool_pose = ToolPose(np.zeros(3), v)
    engine.bind(state)
    half_skin = 0.5 * 0.5 * R  # m
    steps = 200  # 2 mm of travel: 4 half skins of 0.5 mm
    state = engine.run(state, steps, lambda t: ToolPose(v * t, v))
    assert half_skin == pytest.approx(50 * DT * v[2])
    # The bind's build, then (LIGGGHTS' forms) one after 51 steps of travel beyond the last
    # build, decided on the previous step's pose: steps 52, 104 and 156.
    assert engine.n_rebuilds == (4 if forms == 'liggghts' else 1)
