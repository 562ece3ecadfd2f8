"""The library's two design savings (issue 30) are exact where they must be: a pass started
from a shared re-settled bed is the pass with its own re-settle to the bit, and the follow after
the tool stops ends when (and only when) the bed is at rest to the rule's bound. A 324-sphere
bed: seconds."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from dempath_sim.runs import RunOptions, SimResult, run_scene
from dempath_sim.runs.native import keep_settled
from dempath_sim.runs.rest import REST_FRAMES, RestWatch
from dempath_sim.runs.shared_settle import settled_file, settled_key
from dempath_sim.scene import SceneSpec, load_scene

SCENE = """\
name: micro
description: a small bed for the rest-rule and shared-settle tests
seed: 5
bin: {width_x_m: 0.1, length_z_m: 0.14, height_y_m: 0.1}
layers:
  - {name: bed, diameter_m: 0.012, thickness_m: 0.036, distribution: {kind: uniform, spread: 0.1}}
materials:
  particles: {density_kg_m3: 1734, poisson_ratio: 0.25}
  tool: {density_kg_m3: 7800, youngs_modulus_pa: 2.1e11, poisson_ratio: 0.30}
  walls: {density_kg_m3: 7800, youngs_modulus_pa: 2.1e11, poisson_ratio: 0.30}
effects:
  rolling_resistance: {enabled: true, coefficient: 0.26}
tool:
  mesh: builtin:chisel.stl
  scale: 0.5
  depth_m: 0.02
  start_z_m: 0.03
  travel_m: 0.04
  settle_s: 0.02
  profile: {name: micro, speed_m_s: 0.5, acceleration_distance_m: 0.02, steady_distance_m: 0.1}
markers: {spacing_x_m: 0.02, spacing_z_m: 0.02, first_z_m: 0.06,
          cube_size_m: [0.024, 0.024, 0.024]}
fill: {max_settle_time_s: 0.3, settle_speed_m_s: 0.05}
output: {interval_s: 0.01, snapshot_interval_s: 0.02}
sim: {rayleigh_safety: 0.3}
"""
FOLLOW_S = 0.1
FAST = {'tool_speed.speed_scale': 1.5}


@pytest.fixture(scope='module')
def micro(tmp_path_factory: pytest.TempPathFactory) -> tuple[SceneSpec, Path]:
    """The scene and a packing cache holding its poured bed."""
    folder = tmp_path_factory.mktemp('micro')
    path = folder / 'micro.yaml'
    path.write_text(SCENE)
    return load_scene(path), folder / 'packings'


def _run(scene: SceneSpec, cache: Path, **options: object) -> SimResult:
    return run_scene(scene, RunOptions(cache_dir=cache, follow_s=FOLLOW_S,
                                       **options))  # type: ignore[arg-type]


def _same(a: SimResult, b: SimResult) -> None:
    np.testing.assert_array_equal(np.asarray(a.times), np.asarray(b.times))
    np.testing.assert_array_equal(np.asarray(a.tool_force), np.asarray(b.tool_force))
    np.testing.assert_array_equal(np.asarray(a.snapshot_positions),
                                  np.asarray(b.snapshot_positions))


def test_settle_key_ignores_only_the_drive(micro: tuple[SceneSpec, Path]) -> None:
    scene, _ = micro
    key = settled_key(scene)
    assert settled_key(scene.with_overrides(FAST)) == key  # the speed shapes the drive only
    assert settled_key(replace_travel(scene, 0.03)) == key
    for other in ({'particle_friction.static_friction': 0.8},
                  {'tool_friction.static_friction': 0.6},
                  {'youngs_modulus.youngs_modulus_pa': 5e6},
                  {'restitution.particle_particle': 0.45}):
        assert settled_key(scene.with_overrides(other)) != key, other  # contact physics
    assert settled_key(scene.with_overrides(seed=6)) != key  # another packing


def replace_travel(scene: SceneSpec, travel_m: float) -> SceneSpec:
    """``scene`` with another tool travel."""
    from dataclasses import replace

    return replace(scene, tool=replace(scene.tool, travel_m=travel_m))


def test_shared_settle_is_the_own_settle_to_the_bit(micro: tuple[SceneSpec, Path]) -> None:
    scene, cache = micro
    fast = scene.with_overrides(FAST)
    own = _run(fast, cache, shared_settle=True)  # nothing kept yet: it re-settles itself
    assert own.meta['settle_shared'] is False
    assert keep_settled(scene, cache) is True  # the baseline's re-settle, kept
    assert keep_settled(scene, cache) is False  # once
    shared = _run(fast, cache, shared_settle=True)
    assert shared.meta['settle_shared'] is True
    _same(own, shared)
    assert shared.meta['pass_start_springs'] == own.meta['pass_start_springs'] > 0
    base_own, base_shared = _run(scene, cache), _run(scene, cache, shared_settle=True)
    assert base_shared.meta['settle_shared'] is True
    _same(base_own, base_shared)
    other = scene.with_overrides({'particle_friction.static_friction': 0.8})
    assert _run(other, cache, shared_settle=True).meta['settle_shared'] is False


def test_damaged_kept_bed_is_re_settled(micro: tuple[SceneSpec, Path],
                                        caplog: pytest.LogCaptureFixture) -> None:
    scene, cache = micro
    slow = scene.with_overrides({'tool_speed.speed_scale': 0.8})
    keep_settled(scene, cache)
    path = settled_file(slow, cache)
    path.write_bytes(b'not a checkpoint')
    with caplog.at_level(logging.WARNING):
        result = _run(slow, cache, shared_settle=True)
    assert result.meta['settle_shared'] is False
    assert 'damaged' in caplog.text and path.name in caplog.text
    assert not path.exists()


def test_rest_rule_ends_a_bed_at_rest_and_not_a_moving_one(
        micro: tuple[SceneSpec, Path]) -> None:
    scene, cache = micro
    full = _run(scene, cache)
    assert full.meta['rest_at_s'] is None
    moving = _run(scene, cache, rest_tolerance_m=1e-9)  # the bed still moves: followed to the end
    assert moving.meta['rest_at_s'] is None
    _same(full, moving)
    loose = _run(scene, cache, rest_tolerance_m=0.05)  # at rest to 5 cm at once
    stop, rest = full.meta['end_time_s'], loose.meta['rest_at_s']
    frame = float(full.times[1] - full.times[0])
    assert rest == pytest.approx(stop + REST_FRAMES * frame, abs=0.51 * frame)
    np.testing.assert_array_equal(np.asarray(loose.times), np.asarray(full.times))
    before = np.asarray(full.snapshot_times) <= rest + 1e-9
    pos_full, pos_loose = np.asarray(full.snapshot_positions), np.asarray(loose.snapshot_positions)
    np.testing.assert_array_equal(pos_loose[before], pos_full[before])  # stepped as before
    after = np.flatnonzero(~before)
    assert len(after) >= 2
    for k in after[1:]:  # then the last state repeats
        np.testing.assert_array_equal(pos_loose[k], pos_loose[after[0]])
    assert not np.array_equal(pos_full[after[-1]], pos_full[after[0]])  # the full run moved on


def test_rest_watch_bound() -> None:
    ids = np.arange(4)
    pos = np.zeros((4, 3))
    watch = RestWatch(1e-4)
    assert not watch.at_rest(ids, pos, 10)  # the first frame has no step yet
    for _ in range(REST_FRAMES - 1):
        assert not watch.at_rest(ids, pos + 5e-6, 10)  # 5 um a frame x 10 frames left: 50 um
        pos = pos + 5e-6
    assert watch.at_rest(ids[::-1], pos[::-1] + 5e-6, 10)  # matched by id, in any order
    creeping = RestWatch(1e-4)
    for k in range(10):  # 20 um a frame: below the bound for one frame, not for the 10 left
        assert not creeping.at_rest(ids, np.full((4, 3), 2e-5 * k / np.sqrt(3)), 10)
    fewer = RestWatch(1e-4)
    fewer.at_rest(ids, pos, 3)
    fewer.at_rest(ids, pos, 2)
    assert fewer.quiet == 1
    fewer.at_rest(ids[:3], pos[:3], 1)  # a particle left: the count starts again
    assert fewer.quiet == 0


@pytest.mark.parametrize(('tolerance', 'frames'), [(0.0, 3), (-1e-4, 3), (1e-4, 0)])
def test_rest_watch_bad_settings(tolerance: float, frames: int) -> None:
    with pytest.raises(ValueError, match='RestWatch: tolerance_m must be > 0'):
        RestWatch(tolerance, frames)
