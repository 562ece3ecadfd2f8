"""Tool-mesh contact history per patch: carried across triangle edges (with LIGGGHTS' forms only
between coplanar faces), one contact per vertex."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
import pytest
from numpy.typing import NDArray

from dempath_sim.engine import Engine
from dempath_sim.engine.boundary import patch_slot
from dempath_sim.engine.mesh import TriangleMesh, closest_point_triangle_numpy
from dempath_sim.engine.state import SimState
from dempath_sim.engine.walls import Plane

from .mesh_setup import FLOOR, GRAIN, PARAMS, RADIUS, STEEL, flat_patch

OVERLAP = 2.0e-5  # m, held fixed: a steady normal load
F64 = NDArray[np.float64]


def _fan(n: int, size: float, apex_height: float) -> F64:
    """(n, 3, 3) triangles around the apex (0, apex_height, 0), rim of radius size at y = 0."""
    ang = np.linspace(0.0, 2.0 * np.pi, n + 1)
    rim = np.stack([size * np.cos(ang), np.zeros(n + 1), size * np.sin(ang)], axis=1)
    apex = np.array([0.0, apex_height, 0.0])
    return np.array([[apex, rim[k + 1], rim[k]] for k in range(n)])


def _slide(walls: Sequence[Plane], tool: TriangleMesh | None, start: F64,
           velocity: F64, spin: F64, n_steps: int, forms: str = 'dempath') -> F64:
    """Move one sphere at a fixed overlap and velocity; return its (n_steps, 6) force, torque."""
    params = dataclasses.replace(PARAMS, contact_forms=forms)
    state = SimState.from_spheres(start[None, :], np.full(1, RADIUS), 0, params,
                                  velocities=velocity[None])
    state.angular_velocities[0] = spin
    engine = Engine(params, walls=walls, tool=tool)
    engine.bind(state)
    dt = engine.time_step(state)  # the bound time step [s]
    out = np.empty((n_steps, 6))
    on_tool = np.empty((n_steps, 3))  # force of the sphere on the tool [N]
    for k in range(n_steps):
        state.positions[0] += velocity * dt
        engine.contact_forces(state, engine.tool_pose, dt)
        force, torque = engine.forces
        out[k, :3] = force[0]
        out[k, 3:] = torque[0]
        on_tool[k] = engine.tool_force
    if tool is not None:  # the reaction at every step
        np.testing.assert_allclose(on_tool, -out[:, :3], rtol=1e-12, atol=1e-15)
    assert engine.slot_overflows == 0
    return out


@pytest.mark.parametrize(('tris', 'direction'), [
    (flat_patch(1, 0.01), (1.0, 0.0, 0.0)),  # two triangles, across their diagonal
    (flat_patch(8, 0.01), (1.0, 0.0, 0.0)),  # along a grid line: edges and vertices
    (flat_patch(8, 0.01), (0.8, 0.0, 0.6)),  # obliquely across many edges
])
def test_sliding_across_edges_keeps_tangential_force(tris: F64,
                                                     direction: tuple[float, ...]) -> None:
    """A sphere sliding and rolling over the edges of a flat mesh at fixed overlap gets the same
    tangential force and rolling torque (round-off) as on a plane: the springs carry over."""
    velocity = 0.12 * np.asarray(direction)  # m/s
    spin = np.array([0.0, 0.0, -3.0])  # rad/s, builds the rolling spring
    start = np.array([-4.0e-3, RADIUS - OVERLAP, 0.0])
    n_steps = 3000
    plane = _slide(FLOOR, None, start, velocity, spin, n_steps)
    mesh = _slide([], TriangleMesh(tris, material=1), start, velocity, spin, n_steps)
    travel = np.linalg.norm(velocity) * n_steps * Engine(PARAMS).time_step(
        SimState.from_spheres(start[None, :], RADIUS, 0, PARAMS))
    assert travel > 5.0e-3, 'the sphere must cross several edges'
    mu_d = PARAMS.interaction(0, 1).dynamic_friction
    f_t = np.hypot(plane[:, 0], plane[:, 2])
    assert f_t.min() >= mu_d * plane[:, 1].min() > 0.0, 'the sphere must slide (Coulomb)'
    scale = np.abs(plane).max(axis=0)
    np.testing.assert_allclose(mesh, plane, rtol=0, atol=1e-9 * scale.max())
    np.testing.assert_allclose(mesh[:, 3:], plane[:, 3:], rtol=0, atol=1e-9 * scale[3:].max())


def _normal_tangential(tris: F64, centres: F64,
                       forces: F64) -> tuple[F64, F64, NDArray[np.int64]]:
    """Normal force, tangential force magnitude [N] and nearest triangle of each step."""
    f_n = np.empty(len(centres))
    f_t = np.empty(len(centres))
    nearest = np.empty(len(centres), np.int64)
    for k, (p, f) in enumerate(zip(centres, forces, strict=True)):
        q = np.array([closest_point_triangle_numpy(p, tri) for tri in tris])
        dist = np.linalg.norm(p - q, axis=1)
        nearest[k] = int(np.argmin(dist))
        n = (p - q[nearest[k]]) / dist[nearest[k]]
        f_n[k] = f @ n
        f_t[k] = np.linalg.norm(f - f_n[k] * n)
    return f_n, f_t, nearest


@pytest.mark.parametrize('forms', ['dempath', 'liggghts'])
def test_sliding_over_a_convex_ridge(forms: str) -> None:
    """Sliding over a roof ridge (faces 2.9 deg apart) the friction force stays at the Coulomb
    level mu_d F_n when the contact passes from one face to the next with dempath's forms (the
    spring carries over); with LIGGGHTS' forms the spring starts afresh on the new face (LIGGGHTS
    3.8 copies a contact's history from a coplanar neighbour face only), so the friction drops
    there and builds up again to the Coulomb level. Across the flat seams of each face (the
    triangles' diagonals) it carries over with both forms."""
    roof = np.array([[[-0.01, 0.0, -0.01], [0.0, 0.0, 0.01], [0.0, 0.0, -0.01]],
                     [[-0.01, 0.0, -0.01], [-0.01, 0.0, 0.01], [0.0, 0.0, 0.01]],
                     [[0.0, 0.0, -0.01], [0.01, -5e-4, 0.01], [0.01, -5e-4, -0.01]],
                     [[0.0, 0.0, -0.01], [0.0, 0.0, 0.01], [0.01, -5e-4, 0.01]]])
    velocity = np.array([0.05, 0.0, 0.0])  # m/s
    start = np.array([-3.0e-4, RADIUS - OVERLAP, 0.0])
    n_steps = 700
    out = _slide([], TriangleMesh(roof, material=1), start, velocity, np.zeros(3), n_steps,
                 forms)
    dt = Engine(PARAMS).time_step(SimState.from_spheres(start[None, :], RADIUS, 0, PARAMS))
    centres = start + np.outer(np.arange(1, n_steps + 1) * dt, velocity)
    f_n, f_t, nearest = _normal_tangential(roof, centres, out[:, :3])
    assert nearest[0] in (0, 1) and nearest[-1] in (2, 3), 'the contact must change faces'
    assert f_n.min() > 0.3 * f_n.max(), 'the sphere must stay in contact'
    mu_d = PARAMS.interaction(0, 1).dynamic_friction
    slipping = f_t[50:] / (mu_d * f_n[50:])
    ridge = 50 + int(np.argmin(slipping))
    if forms == 'dempath':
        assert slipping.min() > 1.0 - 1e-6, f'friction drops to {slipping.min():.3f} mu_d F_n'
        return
    assert slipping.min() < 0.8, 'the spring must start afresh on the other face'
    assert nearest[ridge] in (2, 3) and nearest[ridge - 1] in (0, 1), 'at the ridge, once'
    assert slipping[ridge - 50 + 100:].min() > 1.0 - 1e-6, 'and slip again on the new face'


def test_sliding_along_a_convex_ridge_keeps_the_friction_with_liggghts_forms() -> None:
    """A sphere sliding along the ridge line itself touches both faces at one point of the
    shared edge: with LIGGGHTS' forms that contact goes on (LIGGGHTS gives the edge to one
    triangle), so the friction stays at the Coulomb level whichever face is the nearest."""
    roof = np.array([[[-0.01, 0.0, -0.01], [0.0, 0.0, 0.01], [0.0, 0.0, -0.01]],
                     [[-0.01, 0.0, -0.01], [-0.01, 0.0, 0.01], [0.0, 0.0, 0.01]],
                     [[0.0, 0.0, -0.01], [0.01, -5e-4, 0.01], [0.01, -5e-4, -0.01]],
                     [[0.0, 0.0, -0.01], [0.0, 0.0, 0.01], [0.01, -5e-4, 0.01]]])
    velocity = np.array([0.0, 0.0, 0.05])  # m/s, along the ridge
    start = np.array([0.0, RADIUS - OVERLAP, -0.004])
    n_steps = 500
    out = _slide([], TriangleMesh(roof, material=1), start, velocity, np.zeros(3), n_steps,
                 'liggghts')
    dt = Engine(PARAMS).time_step(SimState.from_spheres(start[None, :], RADIUS, 0, PARAMS))
    centres = start + np.outer(np.arange(1, n_steps + 1) * dt, velocity)
    f_n, f_t, _ = _normal_tangential(roof, centres, out[:, :3])
    mu_d = PARAMS.interaction(0, 1).dynamic_friction
    slipping = f_t[50:] / (mu_d * f_n[50:])
    assert slipping.min() > 1.0 - 1e-6, f'friction drops to {slipping.min():.3f} mu_d F_n'


ROOF_EDGE = np.array([[[0.0, 0.0, -0.01], [0.0, 0.0, 0.01], [-0.01, 0.0, 0.0]],  # left face
                      [[0.0, 0.0, -0.01], [0.01, -5e-4, 0.0], [0.0, 0.0, 0.01]],  # right face
                      [[0.0, 0.0, 0.01], [-0.01, 0.0, 0.0], [-0.01, 0.0, 0.02]]])  # left again


@pytest.mark.parametrize(('old', 'old_point', 'new_point', 'carried'), [
    (1, (0.0, 0.0, 0.001), (0.0, 0.0, 0.001), True),  # both on the shared edge: goes on
    (1, (0.0, 0.0, 0.001), (-0.001, 0.0, 0.001), False),  # onto the left face: afresh
    (2, (-0.002, 0.0, 0.009), (-0.001, 0.0, 0.001), True),  # coplanar neighbour faces
])
def test_liggghts_forms_carry_a_mesh_spring_where_the_contact_goes_on(
        old: int, old_point: tuple[float, ...], new_point: tuple[float, ...],
        carried: bool) -> None:
    """LIGGGHTS' forms: the nearest triangle 0 takes over the history slot of a triangle of its
    patch only if the contact goes on (same closest point, or a coplanar neighbour face);
    dempath's forms always carry it."""
    for forms, want in ((True, carried), (False, True)):
        cand = np.zeros((2, 9))
        cand[0, :5] = (0, 1e-6, *new_point)
        cand[1, :5] = (old, 1e-6, *old_point)
        cand[:, 5] = (-1.0, 0.0)  # 1 shadowed by 0: one patch
        gkey = np.array([[-1, 7, -1, -1]], np.int32)
        gkey[0, 1] = old  # the patch's slot, keyed to the old triangle (no planes)
        slot = patch_slot(gkey, 0, 0, cand, 2, 0, 0, ROOF_EDGE, forms)
        assert (slot == 1) == want
        assert gkey[0, slot] == 0  # keyed to the nearest triangle now


@pytest.mark.parametrize('apex_height', [0.0, 1.0e-3])
def test_sphere_on_shared_vertex_is_one_contact(apex_height: float) -> None:
    """A sphere centred on the vertex shared by a fan of 7 triangles (flat, or a low cone)
    gets the Hertz force of one contact: the force of a plane at the same overlap."""
    fan = TriangleMesh(_fan(7, 0.01, apex_height), material=1)
    start = np.array([0.0, apex_height + RADIUS - OVERLAP, 0.0])
    state = SimState.from_spheres(start[None, :], RADIUS, 0, PARAMS)
    engine = Engine(PARAMS, tool=fan)
    engine.bind(state)
    plane_state = SimState.from_spheres(np.array([[0.0, RADIUS - OVERLAP, 0.0]]), RADIUS, 0,
                                        PARAMS)
    plane = Engine(PARAMS, walls=FLOOR)
    plane.bind(plane_state)
    e_star = 1.0 / ((1 - 0.25**2) / GRAIN.youngs_modulus + (1 - 0.3**2) / STEEL.youngs_modulus)
    hertz = 4.0 / 3.0 * e_star * np.sqrt(RADIUS) * OVERLAP**1.5
    np.testing.assert_allclose(engine.forces[0][0], [0.0, hertz, 0.0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(plane.forces[0][0], [0.0, hertz, 0.0], rtol=1e-9, atol=1e-12)


def test_sphere_resting_on_vertex_carries_its_weight_once() -> None:
    """A sphere settling under gravity on the shared vertex of a flat fan of 7 triangles comes
    to rest at the Hertz overlap of one contact carrying m g."""
    fan = TriangleMesh(_fan(7, 0.01, 0.0), material=1)
    state = SimState.from_spheres(np.array([[0.0, RADIUS + 1e-5, 0.0]]), RADIUS, 0, PARAMS)
    engine = Engine(PARAMS, tool=fan)
    state = engine.run(state, 6000)
    weight = state.masses[0] * 9.81
    e_star = 1.0 / ((1 - 0.25**2) / GRAIN.youngs_modulus + (1 - 0.3**2) / STEEL.youngs_modulus)
    overlap = (weight / (4.0 / 3.0 * e_star * np.sqrt(RADIUS))) ** (2.0 / 3.0)
    assert abs(state.velocities[0, 1]) < 1e-4, 'the sphere must be at rest'
    assert engine.forces[0][0][1] == pytest.approx(weight, rel=1e-3)
    assert RADIUS - state.positions[0, 1] == pytest.approx(overlap, rel=1e-2)


def test_nearest_triangle_counts_when_many_are_in_reach() -> None:
    """With more triangles in reach than candidate slots (20 small ones listed first, 10 um below
    a plate), the plate still gives the contact: the force of a plane at the same overlap."""
    rng = np.random.default_rng(4)
    small = np.array([[[0.0, 0.0, 0.0], [5e-4, 0.0, 0.0], [0.0, 0.0, 5e-4]]])
    below = small + np.concatenate([rng.uniform(-3e-4, 1e-4, (20, 1, 1)),
                                    np.full((20, 1, 1), -1e-5),
                                    rng.uniform(-3e-4, 1e-4, (20, 1, 1))], axis=2)
    tris = np.concatenate([below, flat_patch(1, 0.01)])
    start = np.array([[1e-4, RADIUS - OVERLAP, 2e-4]])
    engine = Engine(PARAMS, tool=TriangleMesh(tris, material=1))
    engine.bind(SimState.from_spheres(start, np.full(1, RADIUS), 0, PARAMS))
    plane = Engine(PARAMS, walls=FLOOR)
    plane.bind(SimState.from_spheres(start, np.full(1, RADIUS), 0, PARAMS))
    np.testing.assert_allclose(engine.forces[0][0], plane.forces[0][0], rtol=1e-9, atol=1e-12)
