"""Each compiled kernel against a slow, obvious numpy version of the same formula."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dempath_sim.engine.boundary import MAX_CANDIDATES, N_SLOTS, boundary_forces
from dempath_sim.engine.history import PairHistory
from dempath_sim.engine.integrate import first_half, second_half
from dempath_sim.engine.laws.dispatch import build_pair_table
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.mesh import closest_point_triangle, closest_point_triangle_numpy
from dempath_sim.engine.neighbors import build_neighbor_list
from dempath_sim.engine.pair_forces import chunk_windows, pair_forces, reduce_buffers
from dempath_sim.engine.params import SimParams

MATS = (Material('sand', 2650.0, 5.0e6, 0.25), Material('steel', 7800.0, 2.1e11, 0.3))
PARAMS = SimParams(MATS, {
    (0, 0): Interaction(0.3, 0.71, 0.59, rolling_resistance=0.26, cohesion_energy_density=3e4),
    (0, 1): Interaction(0.3, 0.4, 0.3, rolling_resistance=0.1, cohesion_energy_density=1e4)})


def reference_contact(row: np.ndarray, delta: float, r_eff: float, m_eff: float, area: float,
                      n: np.ndarray, v: np.ndarray, w: np.ndarray, xi: np.ndarray,
                      mr: np.ndarray, dt: float) -> tuple[np.ndarray, ...]:
    """Hertz-Mindlin + EPSD2 + SJKR for one contact, in vector form (see the module docs)."""
    e_star, g_star, beta, mu_s, mu_d, mu_r, k_c = row[:7]
    sq = math.sqrt(r_eff * delta)
    f_n = 4 / 3 * e_star * sq * delta - 2 * math.sqrt(5 / 6) * beta * math.sqrt(
        2 * e_star * sq * m_eff) * (v @ n)
    v_t = v - (v @ n) * n
    k_t = 8 * g_star * sq
    gamma_t = 2 * math.sqrt(5 / 6) * beta * math.sqrt(k_t * m_eff)

    def onto_plane(vec: np.ndarray) -> np.ndarray:
        proj = vec - (vec @ n) * n
        norm = np.linalg.norm(proj)
        return proj * np.linalg.norm(vec) / norm if norm > 0 else proj

    xi = onto_plane(xi) + v_t * dt
    f_t = -k_t * xi - gamma_t * v_t
    if np.linalg.norm(f_t) > mu_s * max(f_n, 0):
        f_t = f_t / np.linalg.norm(f_t) * mu_d * max(f_n, 0)
        xi = -(f_t + gamma_t * v_t) / k_t
    mr = onto_plane(mr) - k_t * r_eff ** 2 * (w - (w @ n) * n) * dt
    limit = mu_r * r_eff * max(f_n, 0)
    if np.linalg.norm(mr) > limit:
        mr = mr / np.linalg.norm(mr) * limit
    return (f_n - k_c * area) * n + f_t, mr, xi, mr


def _cluster(rng: np.random.Generator, n: int) -> tuple[np.ndarray, ...]:
    """n spheres (r 1-2 mm) on a jittered 2.8 mm lattice: overlaps, no sphere inside another."""
    axis = np.arange(5) * 2.8e-3
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing='ij'), axis=-1).reshape(-1, 3)
    pos = grid[:n] + rng.uniform(-3e-4, 3e-4, size=(n, 3))
    rad = rng.uniform(1.0e-3, 2.0e-3, n)
    vel = rng.normal(scale=0.2, size=(n, 3))
    omg = rng.normal(scale=30.0, size=(n, 3))
    mass = MATS[0].density * 4 / 3 * np.pi * rad ** 3
    return pos, rad, vel, omg, mass


def test_neighbor_list_matches_brute_force() -> None:
    """The cell-list half list holds exactly the pairs i < j closer than r_i + r_j + skin."""
    rng = np.random.default_rng(4)
    pos = rng.uniform(0.0, 0.05, size=(400, 3))
    rad = np.where(rng.random(400) < 0.2, 5e-3, 1e-3)  # two-size bed
    start, nbr = build_neighbor_list(pos, rad, 3e-4)
    got = {(i, int(j)) for i in range(400) for j in nbr[start[i]:start[i + 1]]}
    d = np.linalg.norm(pos[:, None] - pos[None], axis=-1)
    close = d < rad[:, None] + rad[None] + 3e-4
    want = {(i, j) for i, j in zip(*np.nonzero(close), strict=True) if i < j}
    assert got == want
    longest = int(np.diff(start).max())
    for cap in (1, longest, longest + 5):  # one pass through the table; overflow scans again
        start_c, nbr_c = build_neighbor_list(pos, rad, 3e-4, cap)
        np.testing.assert_array_equal(start_c, start)
        np.testing.assert_array_equal(nbr_c, nbr)


def test_carried_springs_follow_pairs_through_removal() -> None:
    """Springs of overlapping pairs follow their pair when a particle is removed; a pair stored
    (j, i) flips sign; a pair that no longer overlaps starts at zero (and has no row); the rows
    of each chunk lie together in list order."""
    rng = np.random.default_rng(5)
    pos = rng.uniform(0.0, 0.01, size=(60, 3))
    rad = np.full(60, 1e-3)
    start, nbr = build_neighbor_list(pos, rad, 5e-4)
    ht = rng.normal(size=(len(nbr), 3))
    keep = np.ones(60, bool)
    keep[7] = False
    new_to_old = np.flatnonzero(keep)
    order = rng.permutation(len(new_to_old))  # also reorder the survivors
    new_to_old = new_to_old[order]
    nstart, nnbr = build_neighbor_list(pos[new_to_old], rad, 5e-4)
    hist = PairHistory()
    hist.restore({'ht': ht, 'hr': -ht}, start, 2)  # one row per entry, as stored before
    hist.carry(new_to_old, start, nbr, nstart, nnbr, pos[new_to_old], rad, 3)
    nht, nhr = hist.by_entry()
    np.testing.assert_array_equal(nhr, -nht)
    for c in range(3):  # dense rows from the region's base, increasing with the entry
        rows = hist.slot[nstart[c * 59 // 3]:nstart[(c + 1) * 59 // 3]]
        rows = rows[rows >= 0]
        assert len(rows) == hist.live[c] and hist.tail[c] == rows[-1] + 1
        np.testing.assert_array_equal(np.diff(rows), 1)
    old = {(i, int(nbr[k])): ht[k] for i in range(60) for k in range(start[i], start[i + 1])}
    n_kept = 0
    for i in range(len(new_to_old)):
        for k in range(nstart[i], nstart[i + 1]):
            a, b = new_to_old[i], new_to_old[nnbr[k]]
            want = old[(a, b)] if (a, b) in old else -old[(b, a)]
            if np.linalg.norm(pos[a] - pos[b]) >= rad[a] + rad[b]:
                want = np.zeros(3)
            else:
                n_kept += 1
            np.testing.assert_array_equal(nht[k], want)
    assert n_kept > 10


def test_pair_forces_match_reference() -> None:
    """Compiled pair forces, torques and updated springs equal the vector-form reference."""
    rng = np.random.default_rng(6)
    pos, rad, vel, omg, mass = _cluster(rng, 80)
    mat = np.zeros(80, np.int32)
    start, nbr = build_neighbor_list(pos, rad, 2e-4)
    ht = rng.normal(scale=1e-6, size=(len(nbr), 3))
    hr = rng.normal(scale=1e-7, size=(len(nbr), 3))
    tab = build_pair_table(PARAMS)
    dt = 1e-6
    n_chunks = 3
    fbuf = np.full((n_chunks, 80, 3), np.nan)  # rows outside a chunk's window are never read
    tbuf = np.full((n_chunks, 80, 3), np.nan)
    window = np.zeros((n_chunks, 2), np.int64)
    chunk_windows(start, nbr, window)
    assert window[0, 0] == 0 and window[-1, 1] == 80
    force = np.zeros((80, 3))
    torque = np.zeros((80, 3))
    hist = PairHistory()
    hist.restore({'ht': ht, 'hr': hr}, start, n_chunks)
    flags = [np.zeros(80, np.uint8) for _ in range(4)]
    evals = np.zeros(n_chunks, np.int64)
    pair_forces(pos, vel, omg, rad, mass, mat, start, nbr, hist.slot, hist.ht, hist.hr,
                hist.tail, hist.live, tab, dt, True, True, fbuf, tbuf, window,
                np.zeros((n_chunks, 3)), False, *flags, np.inf, evals)
    assert evals.sum() == len(nbr)  # nothing asleep: every listed pair is evaluated
    ht_k, hr_k = hist.by_entry()
    reduce_buffers(fbuf, tbuf, window, force, torque)
    f_ref = np.zeros((80, 3))
    t_ref = np.zeros((80, 3))
    n_touch = 0
    for i in range(80):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            d = np.linalg.norm(pos[i] - pos[j])
            delta = rad[i] + rad[j] - d
            if delta <= 0:
                assert hist.slot[k] == -1  # parted: springs reset, row freed
                continue
            n_touch += 1
            n = (pos[i] - pos[j]) / d
            li, lj = rad[i] - delta / 2, rad[j] - delta / 2
            v = vel[i] + np.cross(omg[i], -li * n) - vel[j] - np.cross(omg[j], lj * n)
            a2 = (rad[i] + rad[j] - d) * (d + rad[i] - rad[j]) * (d - rad[i] + rad[j]) * (
                d + rad[i] + rad[j]) / (4 * d * d)
            f, m, xi, mr = reference_contact(
                tab[0, 0], delta, rad[i] * rad[j] / (rad[i] + rad[j]),
                mass[i] * mass[j] / (mass[i] + mass[j]), np.pi * a2, n, v, omg[i] - omg[j],
                ht[k], hr[k], dt)
            f_ref[i] += f
            f_ref[j] -= f
            t_ref[i] += np.cross(-li * n, f) + m
            t_ref[j] += np.cross(lj * n, -f) - m
            np.testing.assert_allclose(ht_k[k], xi, rtol=1e-9, atol=1e-18)
            np.testing.assert_allclose(hr_k[k], mr, rtol=1e-9, atol=1e-18)
    assert n_touch > 20
    np.testing.assert_allclose(force, f_ref, rtol=1e-9, atol=1e-12 * np.abs(f_ref).max())
    np.testing.assert_allclose(torque, t_ref, rtol=1e-9, atol=1e-12 * np.abs(t_ref).max())


def test_plane_contacts_match_reference() -> None:
    """Compiled particle-plane forces and torques equal the reference (R* = r, m* = m)."""
    rng = np.random.default_rng(7)
    pos, rad, vel, omg, mass = _cluster(rng, 50)
    pos[:, 1] = rng.uniform(0.2e-3, 2.5e-3, 50)
    mat = np.zeros(50, np.int32)
    planes = np.array([[0.0, 0.0, 0.0, 0.0, 1.0, 0.0]])
    tab = build_pair_table(PARAMS)
    gkey = np.full((50, N_SLOTS), -1, np.int32)
    ght = np.zeros((50, N_SLOTS, 3))
    force = np.zeros((50, 3))
    torque = np.zeros((50, 3))
    tool_acc = np.zeros((2, 6))
    dt = 1e-6
    boundary_forces(pos, vel, omg, rad, mass, mat, planes, np.array([1], np.int32),
                    np.zeros((0, 3, 3)), 1, np.zeros(3), 1.0, np.ones(3, np.int64),
                    np.zeros(2, np.int64), np.zeros(0, np.int32), np.zeros(18), gkey, ght,
                    ght.copy(), tab, dt, True, True, force, torque, tool_acc, np.zeros((2, 4)),
                    np.zeros((2, MAX_CANDIDATES, 9)), np.zeros((2, 1, 3)), np.zeros((2, 1, 3)),
                    np.arange(50))
    n = np.array([0.0, 1.0, 0.0])
    for i in range(50):
        s = pos[i, 1]
        if rad[i] - s <= 0:
            np.testing.assert_array_equal(force[i], 0.0)
            assert (gkey[i] == -1).all()
            continue
        delta = rad[i] - s
        v = vel[i] + np.cross(omg[i], -s * n)
        f, m, _, _ = reference_contact(tab[0, 1], delta, rad[i], mass[i],
                                       np.pi * (2 * rad[i] * delta - delta ** 2), n, v, omg[i],
                                       np.zeros(3), np.zeros(3), dt)
        np.testing.assert_allclose(force[i], f, rtol=1e-9)
        np.testing.assert_allclose(torque[i], np.cross(-s * n, f) + m, rtol=1e-9,
                                   atol=1e-15)
        assert gkey[i, 0] == 0


def test_closest_point_matches_reference() -> None:
    """Compiled closest point on a triangle equals the projection/clamping reference."""
    rng = np.random.default_rng(8)
    for _ in range(300):
        tri = rng.normal(size=(3, 3))
        p = rng.normal(scale=2.0, size=3)
        got = np.array(closest_point_triangle(p[0], p[1], p[2], tri))
        np.testing.assert_allclose(got, closest_point_triangle_numpy(p, tri), atol=1e-9)


def test_verlet_halves_match_reference() -> None:
    """The two compiled half steps equal v += dt/2 (F/m + g), x += dt v, w += dt/2 T/I."""
    rng = np.random.default_rng(9)
    pos, rad, vel, omg, mass = _cluster(rng, 30)
    inertia = 0.4 * mass * rad ** 2
    force = rng.normal(size=(30, 3)) * 1e-3
    torque = rng.normal(size=(30, 3)) * 1e-9
    g = np.array([0.0, -9.81, 0.0])
    dt = 1e-5
    p, v, w = pos.copy(), vel.copy(), omg.copy()
    stats = np.zeros((2, 4))
    first_half(p, v, w, force, torque, mass, inertia, rad, g, dt, pos, np.full(3, -1.0),
               np.full(3, 0.01), stats, np.zeros(30, np.uint8))
    v_ref = vel + 0.5 * dt * (force / mass[:, None] + g)
    np.testing.assert_allclose(v, v_ref, rtol=1e-14)
    np.testing.assert_allclose(p, pos + dt * v_ref, rtol=1e-14)
    np.testing.assert_allclose(w, omg + 0.5 * dt * torque / inertia[:, None], rtol=1e-14)
    assert stats[:, 0].max() == pytest.approx(np.max(np.sum((dt * v_ref) ** 2, axis=1)))
    assert stats[:, 2].sum() == np.count_nonzero(np.any(p > 0.01, axis=1))
    second_half(v, w, force, torque, mass, inertia, g, dt, np.zeros(30, np.uint8))
    np.testing.assert_allclose(v, v_ref + 0.5 * dt * (force / mass[:, None] + g), rtol=1e-14)
