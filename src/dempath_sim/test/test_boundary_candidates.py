"""Wall/tool candidate lists give the full pass's forces; the tabulated law equals the formula."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from dempath_sim.engine import Engine, ToolPose
from dempath_sim.engine.laws.dispatch import TAB_CN, TAB_CT, TAB_KN, TAB_KT, build_pair_table
from dempath_sim.engine.laws.hertz_mindlin import hertz_mindlin
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.walls import box_walls

F64 = NDArray[np.float64]
GRAIN = Material('grain', 2500.0, 5.0e7, 0.25)
STEEL = Material('steel', 7800.0, 2.1e11, 0.3)
RADIUS = 2.0e-3  # m
PITCH = 5.0e-3  # m, lattice spacing of the bed (1 mm gaps: room to rearrange)
PARAMS = SimParams((GRAIN, STEEL), {
    (0, 0): Interaction(0.3, 0.71, 0.59, rolling_resistance=0.26),
    (0, 1): Interaction(0.3, 0.4, 0.3, rolling_resistance=0.1)}, max_overlap_fraction=0.2)
TOOL_SPEED = 0.5  # m/s along -Z


def _cube(half: float) -> F64:
    """(12, 3, 3) outward-wound triangles of the cube [-half, half]^3 [m]."""
    tris = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for sign in (-1.0, 1.0):
            quad = []
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = np.zeros(3)
                p[axis], p[u], p[v] = sign * half, a * half, b * half
                quad.append(p)
            tris += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
    return np.array(tris)


def _bed(rng: np.random.Generator) -> SimState:
    """7 x 7 x 7 spheres on a lattice in the bin, random velocities (0.2 m/s) and spins."""
    axis = RADIUS + 0.25e-3 + np.arange(7) * PITCH
    pos = np.stack(np.meshgrid(axis, axis, axis, indexing='ij'), axis=-1).reshape(-1, 3)
    state = SimState.from_spheres(pos, RADIUS, 0, PARAMS,
                                  velocities=rng.normal(scale=0.2, size=pos.shape))
    state.angular_velocities[:] = rng.normal(scale=20.0, size=pos.shape)
    return state


def _run(candidates: bool, n_steps: int) -> tuple[list[F64], Engine]:
    """Step the bed with the cube tool pushed in along -Z; per step force, torque, tool load."""
    top = 2 * RADIUS + 6 * PITCH + 0.5e-3
    walls = box_walls((0.0, 0.0, 0.0), (top, 0.1, top + 0.03))
    engine = Engine(PARAMS, walls=walls, tool=TriangleMesh(_cube(3.0e-3), 1),
                    candidates=candidates)
    state = _bed(np.random.default_rng(11))
    start = np.array([0.5 * top, 0.5 * top, top + 3.2e-3])  # m, tool centre
    speed = np.array([0.0, 0.0, -TOOL_SPEED])

    def motion(t: float) -> ToolPose:
        return ToolPose(start + speed * t, speed)

    out: list[F64] = []

    def record(st: SimState, eng: Engine) -> None:
        force, torque = eng.forces
        out.append(np.concatenate([force.ravel(), torque.ravel(), eng.tool_force,
                                   eng.tool_torque]))
        if eng.candidates:  # particles out of reach hold no wall/tool contact
            idx = eng._reach.indices
            assert idx is not None
            out_of_reach = np.setdiff1d(np.arange(st.n), idx)
            assert (eng._gkey[out_of_reach] == -1).all()
            assert not eng._ght[out_of_reach].any()
            assert not eng._ghr[out_of_reach].any()

    engine.tool_pose = motion(0.0)
    engine.run(state, n_steps, tool_motion=motion, callback=record)
    return out, engine


def test_candidate_lists_match_full_pass() -> None:
    """Over 400 steps with list rebuilds and a moving tool, forces, torques and the tool load
    with the wall/tool candidate lists equal those of the pass over every particle."""
    full, eng_full = _run(False, 400)
    cand, eng_cand = _run(True, 400)
    assert eng_cand.n_rebuilds == eng_full.n_rebuilds > 5
    assert eng_cand._reach.indices is not None
    assert 0 < eng_cand._reach.indices.size < 7 ** 3  # the list leaves the bed's inside out
    tool_load = np.array([row[-6:-3] for row in full])
    assert np.linalg.norm(tool_load, axis=1).max() > 1e-3  # the tool pushes the bed (N)
    for a, b in zip(full, cand, strict=True):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12 * np.abs(a).max())
    np.testing.assert_array_equal(eng_cand._gkey, eng_full._gkey)
    np.testing.assert_allclose(eng_cand._ght, eng_full._ght, rtol=1e-12, atol=1e-18)


def test_candidates_follow_the_tool_between_builds() -> None:
    """A tool outrunning a resting sphere gets its candidates found again while the list stays
    (no rebuild), then hits the sphere with the full pass's forces."""
    still = dataclasses.replace(PARAMS, gravity=(0.0, 0.0, 0.0))
    walls = box_walls((0.0, 0.0, 0.0), (0.03, 0.1, 0.06))
    tool = TriangleMesh(_cube(3.0e-3), 1)
    eng = Engine(still, walls=walls, tool=tool)
    ref = Engine(still, walls=walls, tool=tool, candidates=False)
    states = [SimState.from_spheres(np.array([[0.015, 0.015, 0.02]]), RADIUS, 0, still)
              for _ in range(2)]
    speed = np.array([0.0, 0.0, -1.0])  # m/s; the faces meet after 20 mm

    def motion(t: float) -> ToolPose:
        return ToolPose(np.array([0.015, 0.015, 0.045]) + speed * t, speed)

    searches = 0
    eng.tool_pose = ref.tool_pose = motion(0.0)
    while states[0].time < 0.03:
        pose = motion(states[0].time + eng.time_step(states[0]))
        states = [eng.step(states[0], pose), ref.step(states[1], pose)]
        if eng.n_rebuilds == 1:
            searches += eng._reach.pose is eng._packed[1]  # found for this step's pose
        np.testing.assert_allclose(eng.forces[0], ref.forces[0], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(eng.tool_force, ref.tool_force, rtol=1e-12, atol=1e-15)
    assert states[0].velocities[0, 2] < -0.5  # the tool hit and pushed the sphere (m/s)
    assert searches >= 4  # 20 mm of travel, a new search every 2 skins (2.4 mm)


@njit(cache=True)
def _law(delta, r_eff, m_eff, row, nx, ny, nz, vx, vy, vz, hist, dt):  # pragma: no cover
    """The compiled law with the pair table's precomputed constants."""
    return hertz_mindlin(delta, r_eff, m_eff, row[TAB_KN], row[TAB_KT], row[TAB_CN],
                         row[TAB_CT], row[3], row[4], nx, ny, nz, vx, vy, vz, hist, 0, dt)


def _old_law(row: F64, delta: float, r_eff: float, m_eff: float, n: F64, v: F64,
             xi: F64, dt: float) -> tuple[float, F64, F64]:
    """The law written from E*, G* and beta, three square roots (as before the table)."""
    e_star, g_star, beta, mu_s, mu_d = row[:5]
    sq = math.sqrt(r_eff * delta)
    v_n = float(v @ n)
    f_n = 4 / 3 * e_star * sq * delta - 2 * math.sqrt(5 / 6) * beta * math.sqrt(
        2 * e_star * sq * m_eff) * v_n
    k_t = 8 * g_star * sq
    gamma_t = 2 * math.sqrt(5 / 6) * beta * math.sqrt(k_t * m_eff)
    v_t = v - v_n * n
    proj = xi - (xi @ n) * n
    if np.linalg.norm(proj) > 0:
        proj *= np.linalg.norm(xi) / np.linalg.norm(proj)
    xi = proj + v_t * dt
    f_t = -k_t * xi - gamma_t * v_t
    if np.linalg.norm(f_t) > mu_s * max(f_n, 0):
        f_t = f_t / np.linalg.norm(f_t) * mu_d * max(f_n, 0)
        xi = -(f_t + gamma_t * v_t) / k_t
    return f_n, f_t, xi


def test_precomputed_law_equals_formula() -> None:
    """On random contacts (both material pairs, sticking and sliding) the law with the table's
    precomputed constants gives the old formula's forces and springs to round-off."""
    rng = np.random.default_rng(5)
    tab = build_pair_table(PARAMS)
    for k in range(400):
        row = tab[0, k % 2]
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        delta = rng.uniform(1e-7, 1e-4)
        r_eff, m_eff = rng.uniform(5e-4, 4e-3), rng.uniform(1e-5, 1e-3)
        v = rng.normal(scale=0.5, size=3)
        xi = rng.normal(scale=10 ** rng.uniform(-8, -5), size=3)
        hist = xi[None, :].copy()
        f_n, ftx, fty, ftz, _ = _law(delta, r_eff, m_eff, row, *n, *v, hist, 1e-6)
        ref_n, ref_t, ref_xi = _old_law(row, delta, r_eff, m_eff, n, v, xi, 1e-6)
        scale = abs(ref_n) + np.linalg.norm(ref_t)
        assert abs(f_n - ref_n) <= 1e-12 * scale
        np.testing.assert_allclose([ftx, fty, ftz], ref_t, rtol=1e-11, atol=1e-12 * scale)
        np.testing.assert_allclose(hist[0], ref_xi, rtol=1e-11,
                                   atol=1e-12 * np.abs(ref_xi).max())
