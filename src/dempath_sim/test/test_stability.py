"""Runs finish when the physics is sound and stop, saying what to change, when it is not.

Soft sand (E = 1.7 MPa) overlaps by more than half a radius under a tool with every contact
resolved by the time step: such a run must finish. A time step the contacts cannot follow must
stop with one error line naming the setting.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from dempath_sim.cli import simulate_main
from dempath_sim.engine import Engine, ToolPose
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.stability import contact_stable_step
from dempath_sim.engine.state import SimState
from dempath_sim.engine.timestep import rayleigh_time_step
from dempath_sim.engine.walls import Plane
from dempath_sim.runs import build_params
from dempath_sim.scene import SCENES_DIR, load_scene

from .mesh_setup import flat_patch

SAND = Material('sand', 1734.0, 1.7e6, 0.25)  # the paper's Table 6 sand
STEEL = Material('steel', 7800.0, 2.1e11, 0.3)
RADIUS = 4.5e-3  # m
SQUEEZE_SPEED = 0.05  # m/s, the plate's descent


def _squeeze(depth: float) -> tuple[SimState, Engine, float]:
    """A sand grain on a steel floor pressed by a descending steel plate until the plate has
    come ``depth`` [m] closer than touching; returns the state, the engine and the time step."""
    params = SimParams((SAND, STEEL), {(0, 0): Interaction(0.3, 0.71, 0.71),
                                       (0, 1): Interaction(0.3, 0.4, 0.4)}, dt=5e-5)
    floor = (Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 1),)
    plate = TriangleMesh(flat_patch(2, 0.02), material=1, name='plate')
    state = SimState.from_spheres(np.array([[0.0, RADIUS, 0.0]]), np.full(1, RADIUS), 0,
                                  params)
    engine = Engine(params, walls=floor, tool=plate)
    top = 2.0 * RADIUS
    n = math.ceil(depth / SQUEEZE_SPEED / 5e-5)

    def pose(t: float) -> ToolPose:
        return ToolPose(np.array([0.0, top - SQUEEZE_SPEED * t, 0.0]),
                        np.array([0.0, -SQUEEZE_SPEED, 0.0]))

    engine.tool_pose = pose(0.0)
    return engine.run(state, n, tool_motion=pose), engine, top - SQUEEZE_SPEED * n * 5e-5


def test_soft_grain_squeezed_past_half_a_radius_finishes() -> None:
    """A 9 mm sand grain squeezed between floor and plate to ~65 % of its radius at each
    contact runs to the end (the old 50 % stop would have ended it) and carries the Hertz force
    of that overlap: the contacts are deep and sound."""
    state, engine, plate_y = _squeeze(1.3 * RADIUS)
    y = float(state.positions[0, 1])
    d_floor, d_plate = RADIUS - y, RADIUS - (plate_y - y)
    assert min(d_floor, d_plate) > 0.6 * RADIUS
    e_star = 1.0 / ((1 - 0.25**2) / 1.7e6 + (1 - 0.3**2) / 2.1e11)
    hertz = 4.0 / 3.0 * e_star * math.sqrt(RADIUS) * d_plate**1.5
    assert engine.tool_force[1] == pytest.approx(hertz, rel=0.05)
    mass = float(state.masses[0])
    limit = contact_stable_step(engine.params, 0, 1, RADIUS, mass, d_plate)
    assert limit > 5 * float(engine.dt or 0.0)  # resolved with a wide margin


def test_time_step_the_contacts_cannot_follow_stops_with_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The tiny scene at 0.9 of the Rayleigh step (accepted by the Rayleigh check) cannot
    resolve its settling contacts: `dempath simulate` prints one `error:` line naming the
    contact, the step it needs and the scene key to change, and writes no results."""
    data = yaml.safe_load((SCENES_DIR / 'tiny.yaml').read_text())
    scene = load_scene(SCENES_DIR / 'tiny.yaml')
    layer = scene.layers[0]
    r_min = layer.diameter_m * (1 - layer.distribution.spread) / 2
    params = build_params(scene, scene.physics_model())
    dt_r = rayleigh_time_step(np.array([r_min]), np.zeros(1, np.int32), params)
    data['sim']['time_step_s'] = 0.9 * dt_r
    path = tmp_path / 'too_coarse.yaml'
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / 'out'
    code = simulate_main([str(path), '--out', str(out), '--quiet',
                          '--cache-dir', str(tmp_path / 'cache')])
    err = capsys.readouterr().err.strip().splitlines()
    errors = [line for line in err if line.startswith('error:')]
    assert code == 1 and len(errors) == 1, err
    assert 'unstable contact between particle' in errors[0]
    assert 'set sim.time_step_s to' in errors[0] and 'needs dt <=' in errors[0]
    assert not (out / 'summary.json').exists()
