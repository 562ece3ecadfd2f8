"""Cell-order sorting of the particles at list builds: same trajectories, ids follow particles."""

from __future__ import annotations

import numpy as np

from dempath_sim.engine import Engine
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.neighbors import build_neighbor_list, cell_order
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.walls import box_walls

SAND = Material('sand', 2650.0, 5.0e6, 0.25)
STEEL = Material('steel', 7800.0, 2.1e11, 0.3)
PARAMS = SimParams((SAND, STEEL), {
    (0, 0): Interaction(0.3, 0.7, 0.6, rolling_resistance=0.2),
    (0, 1): Interaction(0.3, 0.4, 0.3, rolling_resistance=0.2)},
    domain_min=(-0.05, -0.01, -0.05), domain_max=(0.05, 0.06, 0.05),
    max_overlap_fraction=0.2)
LO, HI = (-0.02, 0.0, -0.02), (0.02, 0.2, 0.02)  # m


def _bed(seed: int) -> SimState:
    """~600 polydisperse spheres in shuffled order, falling into a bin; the top one flies out."""
    rng = np.random.default_rng(seed)
    axis = np.arange(-0.018, 0.018, 4.0e-3)
    pos = np.stack(np.meshgrid(axis, 0.003 + 4.0e-3 * np.arange(8), axis, indexing='ij'),
                   axis=-1).reshape(-1, 3)
    pos = pos[rng.permutation(len(pos))] + rng.uniform(-2e-4, 2e-4, size=pos.shape)
    vel = rng.normal(scale=0.2, size=pos.shape)
    vel[np.argmax(pos[:, 1])] = (0.0, 12.0, 0.0)  # the top sphere leaves the domain: removal
    state = SimState.from_spheres(pos, rng.uniform(1.6e-3, 1.95e-3, len(pos)), 0, PARAMS,
                                  velocities=vel, ids=1000 + np.arange(len(pos)))
    state.extra['tag'] = 7 * state.ids
    return state


def _run(reorder: bool, steps: int) -> tuple[SimState, Engine]:
    engine = Engine(PARAMS, walls=box_walls(LO, HI, material=1), reorder=reorder)
    engine.REORDER_MIN = 0  # sort this small bed too
    return engine.run(_bed(3), steps), engine


def _by_id(state: SimState, values: np.ndarray) -> np.ndarray:
    return values[np.argsort(state.ids)]


def test_sorted_engine_matches_unsorted_to_round_off() -> None:
    """Sorted and unsorted runs give the same positions, velocities, spins and forces by id;
    two sorted runs are bitwise equal."""
    plain, e_plain = _run(False, 500)
    fast, e_fast = _run(True, 500)
    assert e_fast.n_rebuilds > 20 and e_fast.removed_count == e_plain.removed_count == 1
    assert not np.array_equal(fast.ids, plain.ids), 'the sorted run must have reordered'
    assert np.array_equal(np.sort(fast.ids), np.sort(plain.ids))
    assert e_plain.n_contacts > 100, 'the bed must be in contact for the test to mean something'
    # round-off grows chaotically in a dense bed (~1e-15 m at 400 steps, 1e-5 m at 1000; spins
    # reach ~2e-9 relative at 500 steps): 1e-7 of the largest value is far below any physical
    # difference (a wrong history or force would be of order 1) while the list is rebuilt ~40
    # times
    for name in ('positions', 'velocities', 'angular_velocities'):
        a = _by_id(plain, getattr(plain, name))
        b = _by_id(fast, getattr(fast, name))
        assert np.abs(a - b).max() <= 1e-7 * np.abs(a).max(), name
    again, _ = _run(True, 500)
    assert np.array_equal(again.positions, fast.positions), 'sorted runs must be deterministic'
    assert np.array_equal(again.ids, fast.ids)
    f_a = _by_id(plain, e_plain.forces[0])
    f_b = _by_id(fast, e_fast.forces[0])
    assert np.abs(f_a - f_b).max() <= 1e-6 * np.abs(f_a).max()


def test_ids_radii_and_extra_follow_the_particles() -> None:
    """After sorting, every per-particle field still belongs to the same id."""
    start = _bed(3)
    radius_of = dict(zip(start.ids.tolist(), start.radii.tolist(), strict=True))
    fast, engine = _run(True, 200)
    flown = start.ids[np.argmax(start.positions[:, 1])]
    assert engine.removed_count == 1 and flown not in fast.ids
    assert np.array_equal(fast.extra['tag'], 7 * fast.ids)
    assert all(radius_of[i] == r for i, r in zip(fast.ids.tolist(), fast.radii.tolist(),
                                                 strict=True))
    np.testing.assert_allclose(fast.masses, SAND.density * 4 / 3 * np.pi * fast.radii ** 3)
    np.testing.assert_allclose(fast.inertias, 0.4 * fast.masses * fast.radii ** 2)


def test_reorder_permutes_every_field() -> None:
    """SimState.reorder moves rows of all arrays and extras together (row k = old order[k])."""
    state = _bed(5)
    before = {k: np.copy(v) for k, v in vars(state).items() if isinstance(v, np.ndarray)}
    order = np.random.default_rng(0).permutation(state.n)
    state.reorder(order)
    for name, old in before.items():
        assert np.array_equal(getattr(state, name), old[order]), name
    assert np.array_equal(state.extra['tag'], 7 * state.ids)


def test_forward_scan_on_sorted_particles_matches_brute_force() -> None:
    """On cell-sorted particles the forward half-stencil scan finds exactly the pairs i < j."""
    rng = np.random.default_rng(6)
    pos = rng.uniform(0.0, 0.05, size=(500, 3))
    rad = np.where(rng.random(500) < 0.2, 5e-3, 1e-3)  # two-size bed: wide stencils too
    order = cell_order(pos, rad, 3e-4)
    assert not np.array_equal(order, np.arange(500))
    pos, rad = pos[order], rad[order]
    np.testing.assert_array_equal(cell_order(pos, rad, 3e-4), np.arange(500))  # now sorted
    start, nbr = build_neighbor_list(pos, rad, 3e-4)
    got = {(i, int(j)) for i in range(500) for j in nbr[start[i]:start[i + 1]]}
    d = np.linalg.norm(pos[:, None] - pos[None], axis=-1)
    close = d < rad[:, None] + rad[None] + 3e-4
    assert got == {(i, j) for i, j in zip(*np.nonzero(close), strict=True) if i < j}
    assert len(got) == len(nbr) > 300
