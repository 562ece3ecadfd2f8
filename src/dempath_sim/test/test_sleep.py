"""Sleeping far field (engine/sleep.py) on the real engine: a bed at rest sleeps and costs almost
no pair work, the tool and a moving neighbour wake grains in time, and with nothing asleep the
engine computes exactly what it computes with sleeping off."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dempath_sim.engine import Engine, SimState, ToolPose, TriangleMesh
from dempath_sim.engine.energy import total_energy
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.sleep import SleepSettings
from dempath_sim.engine.walls import box_walls

SAND = Material('sand', 2650.0, 1.7e6, 0.25)  # the paper's soft sand (Table 6)
STEEL = Material('steel', 7800.0, 2.1e11, 0.3)
RADIUS = 2.0e-3  # m
PARAMS = SimParams((SAND, STEEL), {(0, 0): Interaction(0.3, 0.71, 0.59, rolling_resistance=0.26),
                                   (0, 1): Interaction(0.3, 0.4, 0.3, rolling_resistance=0.26)})
LO, HI = (-0.016, 0.0, -0.016), (0.016, 0.1, 0.064)  # m, the bin (80 mm long in Z)
WALLS = box_walls(LO, HI, material=1)


def _lattice(layers: int, seed: int = 1) -> SimState:
    """Spheres on a jittered lattice in the bin (they fall and settle)."""
    rng = np.random.default_rng(seed)
    step = 2.1 * RADIUS
    xs = np.arange(LO[0] + 1.2 * RADIUS, HI[0] - RADIUS, step)
    ys = 1.2 * RADIUS + step * np.arange(layers)
    zs = np.arange(LO[2] + 1.2 * RADIUS, HI[2] - RADIUS, step)
    pos = np.stack(np.meshgrid(xs, ys, zs, indexing='ij'), axis=-1).reshape(-1, 3)
    pos += rng.uniform(-0.05, 0.05, size=pos.shape) * RADIUS
    return SimState.from_spheres(pos, RADIUS, 0, PARAMS)


@pytest.fixture(scope='module')
def settled() -> SimState:
    """A bed of 756 grains settled without sleeping (0.5 s), history dropped, at rest."""
    state = Engine(PARAMS, WALLS).run(_lattice(6), 6000)
    return SimState.from_spheres(state.positions, state.radii, 0, PARAMS)


def _copy(state: SimState) -> SimState:
    return state.subset(np.ones(state.n, bool))


def test_bed_at_rest_sleeps_and_costs_almost_nothing(settled: SimState) -> None:
    """Once the bed is quiet, nearly every grain sleeps, the sleeping ones do not move at all,
    and the pair work per step falls to a small part of the listed pairs (a count, not a time)."""
    engine = Engine(PARAMS, WALLS, sleep=SleepSettings())
    state = engine.run(_copy(settled), 1500)
    pairs = engine.n_pairs
    before = state.positions.copy()
    asleep = engine.asleep
    evals0 = engine.pair_evaluations
    still = asleep.copy()

    def asleep_throughout(_: SimState, eng: Engine) -> None:
        still[:] &= eng.asleep

    state = engine.run(state, 500, callback=asleep_throughout)
    per_step = (engine.pair_evaluations - evals0) / 500
    assert asleep.mean() > 0.9, f'{asleep.mean():.1%} asleep'
    assert still.mean() > 0.85
    assert np.array_equal(state.positions[still], before[still])  # exactly at rest
    moved = np.linalg.norm(state.positions - before, axis=1).max()
    awake_engine = Engine(PARAMS, WALLS)  # the same steps without sleeping
    ref = awake_engine.run(_copy(settled), 1500)
    ref_before = ref.positions.copy()
    evals0 = awake_engine.pair_evaluations
    ref = awake_engine.run(ref, 500)
    ref_per_step = (awake_engine.pair_evaluations - evals0) / 500
    ref_moved = np.linalg.norm(ref.positions - ref_before, axis=1).max()
    print(f'asleep {asleep.mean():.3f}, pair evaluations {per_step / pairs:.3f} of the list '
          f'(awake: {ref_per_step / awake_engine.n_pairs:.3f}), largest creep '
          f'{moved / RADIUS:.2e} radii (awake: {ref_moved / RADIUS:.2e})')
    assert ref_per_step >= awake_engine.n_pairs  # without sleeping every listed pair, each step
    assert per_step < 0.25 * pairs, f'{per_step:.0f} pair evaluations per step of {pairs}'
    # the grains still awake (spinning on the floor, a rattler) creep as they do without
    # sleeping: a few hundredths of a radius in 500 steps
    assert moved <= 2.0 * ref_moved + 1e-3 * RADIUS, 'the sleeping bed crept more than the awake'


def _plate(width: float, height: float) -> TriangleMesh:
    """A vertical plate in the X-Y plane (normal Z), its lower edge at y = 0 of its frame."""
    w = width / 2
    tris = np.array([[[-w, 0.0, 0.0], [w, 0.0, 0.0], [w, height, 0.0]],
                     [[-w, 0.0, 0.0], [w, height, 0.0], [-w, height, 0.0]]])
    return TriangleMesh(tris, material=1)


def test_tool_and_moving_neighbours_wake_grains_in_time(settled: SimState) -> None:
    """A plate driven into a sleeping bed touches awake grains only, and at the end of every
    step no sleeping grain touches an awake grain that moves faster than the wake speed (a
    grain hit moves its neighbours, which wake at the same step)."""
    settings = SleepSettings()
    engine = Engine(PARAMS, WALLS, tool=_plate(0.012, 0.05), sleep=settings)
    speed = 0.5  # m/s along +Z
    start = np.array([0.0, 0.006, LO[2] + 0.002])
    bed = _copy(settled)
    in_slot = (np.abs(bed.positions[:, 2] - start[2]) < RADIUS) & (bed.positions[:, 1] > 0.006)
    bed = bed.subset(~in_slot)
    engine.tool_pose = ToolPose(start, np.zeros(3))
    state = engine.run(bed, 2500)  # the bed falls asleep round the standing plate
    assert engine.asleep.mean() > 0.5
    t0 = state.time
    v_wake = settings.wake_speed_fraction * 9.81 * float(engine.dt or 0.0)
    worst = 0.0
    woken0 = engine.woken

    def motion(t: float) -> ToolPose:
        return ToolPose(start + np.array([0.0, 0.0, speed * (t - t0)]),
                        np.array([0.0, 0.0, speed]))

    def check(st: SimState, eng: Engine) -> None:
        nonlocal worst
        asleep = eng.asleep
        mesh_keys = eng._gkey >= len(WALLS)  # a slot held by a tool triangle
        assert not np.any(mesh_keys.any(axis=1) & asleep), 'the tool touches a sleeping grain'
        i = np.repeat(np.arange(st.n), np.diff(eng._start))
        j = eng._nbr
        d = np.linalg.norm(st.positions[i] - st.positions[j], axis=1)
        touch = d < st.radii[i] + st.radii[j]
        speed_ = np.linalg.norm(st.velocities, axis=1)
        for s, a in ((i, j), (j, i)):
            mixed = touch & asleep[s] & ~asleep[a]
            if mixed.any():
                worst = max(worst, float(speed_[a[mixed]].max()))

    state = engine.run(state, 600, tool_motion=motion, callback=check)
    assert np.linalg.norm(engine.tool_force) > 0.0, 'the plate must push grains'
    assert engine.woken - woken0 > 20, 'the plate must wake grains'
    # the half-step speed decides in the pair pass; the end-of-step speed may differ a little
    assert worst < 2.0 * v_wake, f'a sleeping grain touches one moving at {worst / v_wake:.1f} ' \
                                 'x the wake speed'


def test_nothing_asleep_same_run_and_budgets() -> None:
    """With sleeping on and no grain quiet long enough (a falling bed, a moving plate), the
    run is the run with sleeping off: same positions, energy and momentum to rounding."""
    settings = SleepSettings(quiet_steps=10_000)
    runs = []
    for sleep in (None, settings):
        engine = Engine(PARAMS, WALLS, tool=_plate(0.012, 0.05), sleep=sleep)
        start = np.array([0.0, 0.004, LO[2] + 0.002])

        def motion(t: float, start: np.ndarray = start) -> ToolPose:
            return ToolPose(start + np.array([0.0, 0.0, 0.3 * t]), np.array([0.0, 0.0, 0.3]))

        state = engine.run(_lattice(3, seed=3), 2000, tool_motion=motion)
        momentum = (state.masses[:, None] * state.velocities).sum(axis=0)
        runs.append((state, total_energy(state, PARAMS, WALLS), momentum,
                     engine.tool_force.copy(), engine.n_asleep))
    (off, e_off, p_off, f_off, _), (on, e_on, p_on, f_on, n_asleep) = runs
    assert n_asleep == 0
    np.testing.assert_allclose(on.positions, off.positions, rtol=0, atol=1e-12 * RADIUS)
    np.testing.assert_allclose(on.velocities, off.velocities, rtol=1e-12, atol=1e-15)
    assert e_on == pytest.approx(e_off, rel=1e-12)
    np.testing.assert_allclose(p_on, p_off, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(f_on, f_off, rtol=1e-12, atol=1e-15)


def test_settings_are_checked() -> None:
    """Thresholds out of range are refused with the field's name."""
    with pytest.raises(ValueError, match='force_fraction'):
        SleepSettings(force_fraction=0.0)
    with pytest.raises(ValueError, match='wake_speed_fraction'):
        SleepSettings(speed_fraction=2.0, wake_speed_fraction=1.0)
    with pytest.raises(ValueError, match='quiet_steps'):
        dataclasses.replace(SleepSettings(), quiet_steps=0)
    loose = SleepSettings().scaled(10.0)
    assert loose.speed_fraction == 5.0 and loose.wake_force_fraction == 10.0
    assert loose.quiet_steps == SleepSettings().quiet_steps


def test_checkpoint_resumes_the_run(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A run written to disk half way and resumed in a new engine ends where the uninterrupted
    run ends (particles to rounding), sleep state and springs included."""
    settings = SleepSettings(quiet_steps=50)
    start = np.array([0.0, 0.004, LO[2] + 0.002])

    def motion(t: float) -> ToolPose:
        return ToolPose(start + np.array([0.0, 0.0, 0.3 * t]), np.array([0.0, 0.0, 0.3]))

    def engine() -> Engine:
        return Engine(PARAMS, WALLS, tool=_plate(0.012, 0.05), sleep=settings)

    whole = engine()
    ref = whole.run(_lattice(3, seed=4), 1600, tool_motion=motion)
    first = engine()
    half = first.run(_lattice(3, seed=4), 800, tool_motion=motion)
    np.savez(tmp_path / 'cp.npz', **first.checkpoint(half))
    second = engine()
    with np.load(tmp_path / 'cp.npz') as data:
        resumed = second.resume(data)
    assert resumed.step == 800 and second.n_asleep == first.n_asleep
    out = second.run(resumed, 800, tool_motion=motion)
    assert whole.n_asleep > 0  # the sleep state went through the checkpoint
    np.testing.assert_allclose(out.positions, ref.positions, rtol=0, atol=1e-9 * RADIUS)
    np.testing.assert_allclose(out.velocities, ref.velocities, rtol=1e-6, atol=1e-9)
    assert second.n_asleep == whole.n_asleep
    assert second.pair_evaluations == whole.pair_evaluations
