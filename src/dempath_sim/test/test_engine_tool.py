"""The triangle-mesh tool: same laws as a plane, one force per contact, moving tool, reaction."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest

from dempath_sim.engine import Engine, ToolPose
from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.walls import Plane

from .mesh_setup import FLOOR, PARAMS, RADIUS, flat_patch


def _bounce(walls: Sequence[Plane], tool: TriangleMesh | None, start: np.ndarray,
            spin: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """Drop one spinning sphere; return its (steps, 6) position/velocity track and tool forces."""
    state = SimState.from_spheres(start[None, :], RADIUS, 0, PARAMS,
                                  velocities=np.array([[0.05, -0.5, 0.02]]))
    state.angular_velocities[0] = spin
    engine = Engine(PARAMS, walls=walls, tool=tool)
    track: list[np.ndarray] = []
    forces: list[np.ndarray] = []

    def record(st: SimState, eng: Engine) -> None:
        track.append(np.concatenate([st.positions[0], st.velocities[0]]))
        forces.append(np.concatenate([eng.tool_force, eng.forces[0][0]]))

    engine.run(state, 600, callback=record)
    return np.array(track), forces


@pytest.mark.parametrize('start_x', [0.0, 0.3e-3, 1.25e-3])
def test_tiled_flat_mesh_acts_like_one_plane(start_x: float) -> None:
    """A sphere bouncing on a flat mesh of many triangles (landing on a face, near an edge, on a
    vertex) follows the same track as on a plane: each contact counts once."""
    start = np.array([start_x, RADIUS + 1e-4, 0.0])
    spin = np.array([3.0, 0.0, -2.0])
    plane_track, _ = _bounce(FLOOR, None, start, spin)
    mesh = TriangleMesh(flat_patch(8, 0.01), material=1)
    mesh_track, forces = _bounce([], mesh, start, spin)
    assert plane_track[:, 4].max() > 0.1, 'the sphere must bounce'
    np.testing.assert_allclose(mesh_track, plane_track, rtol=0, atol=1e-9)
    for f in forces:
        np.testing.assert_allclose(f[:3], -f[3:], atol=1e-12)


def test_convex_ridge_contact_counts_once() -> None:
    """A sphere landing on a convex roof ridge (4 triangles share the line) bounces as on a
    plane touching the ridge line."""
    roof = np.array([[[-0.01, 0.0, 0.0], [0.01, 0.0, 0.0], [0.01, -0.005, 0.01]],
                     [[-0.01, 0.0, 0.0], [0.01, -0.005, 0.01], [-0.01, -0.005, 0.01]],
                     [[-0.01, 0.0, 0.0], [0.01, -0.005, -0.01], [0.01, 0.0, 0.0]],
                     [[-0.01, 0.0, 0.0], [-0.01, -0.005, -0.01], [0.01, -0.005, -0.01]]])
    start = np.array([0.0, RADIUS + 1e-4, 0.0])
    state = SimState.from_spheres(start[None, :], RADIUS, 0, PARAMS,
                                  velocities=np.array([[0.0, -0.5, 0.0]]))
    engine = Engine(PARAMS, tool=TriangleMesh(roof, material=1))
    state = engine.run(state, 400)
    plane_state = SimState.from_spheres(start[None, :], RADIUS, 0, PARAMS,
                                        velocities=np.array([[0.0, -0.5, 0.0]]))
    plane = Engine(PARAMS, walls=FLOOR)
    plane_state = plane.run(plane_state, 400)
    assert state.velocities[0, 1] > 0.1
    np.testing.assert_allclose(state.velocities[0], plane_state.velocities[0], atol=1e-9)


def test_moving_tool_pushes_sphere_with_restitution() -> None:
    """A plate moving at u along +Z sends a resting sphere off at (1 + e) u (no gravity)."""
    params = SimParams(PARAMS.materials, PARAMS.interactions, gravity=(0.0, 0.0, 0.0))
    plate = np.array([[[-0.01, -0.01, 0.0], [0.01, -0.01, 0.0], [0.01, 0.01, 0.0]],
                      [[-0.01, -0.01, 0.0], [0.01, 0.01, 0.0], [-0.01, 0.01, 0.0]]])
    speed = 0.4
    state = SimState.from_spheres(np.array([[0.001, 0.002, RADIUS + 1e-4]]), RADIUS, 0, params)
    engine = Engine(params, tool=TriangleMesh(plate, material=1))
    impulse = np.zeros(3)

    def add_impulse(_: SimState, eng: Engine) -> None:
        impulse[:] += eng.tool_force * eng.dt

    def motion(t: float) -> ToolPose:
        return ToolPose(np.array([0.0, 0.0, speed * t]), np.array([0.0, 0.0, speed]))

    state = engine.run(state, 1500, tool_motion=motion, callback=add_impulse)
    assert state.velocities[0, 2] == pytest.approx(1.5 * speed, rel=0.02)
    momentum = state.masses[0] * state.velocities[0]
    np.testing.assert_allclose(-impulse, momentum, rtol=1e-6, atol=1e-12)
