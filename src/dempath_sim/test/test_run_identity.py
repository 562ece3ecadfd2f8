"""What a run is, in its metadata: scene and physics keys, seed and tool speed (runs.identity)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from dempath_sim.cli import simulate_main
from dempath_sim.runs import run_identity
from dempath_sim.runs.identity import physics_key, run_id, scene_key
from dempath_sim.scene import bundled_scene


def test_keys_separate_set_up_physics_and_seed() -> None:
    """A seed changes neither key; an effect the physics key only; another set-up the scene's."""
    base = bundled_scene('tiny')
    reseeded = base.with_overrides({}, seed=base.seed + 4)
    assert (scene_key(reseeded), physics_key(reseeded)) == (scene_key(base), physics_key(base))
    assert run_id(reseeded) != run_id(base)
    stronger = base.with_overrides({'cohesion.energy_density_j_m3': 2e5}, on=['cohesion'])
    assert scene_key(stronger) == scene_key(base)
    assert physics_key(stronger) != physics_key(base)
    other = bundled_scene('reduced_1ms')
    assert scene_key(other) != scene_key(base)


def test_tool_speed_is_the_profiles_and_the_effect_scales_the_drive() -> None:
    """tool_speed_m_s is the nominal speed; the tool_speed effect is physics (scale, driven)."""
    scene = bundled_scene('reduced_1ms')
    nominal = run_identity(scene)
    assert nominal.tool_speed_m_s == pytest.approx(scene.tool.profile.speed_m_s)
    assert nominal.tool_speed_m_s == pytest.approx(1.0)
    scaled = run_identity(scene.with_overrides({'tool_speed.speed_scale': 1.5},
                                               on=['tool_speed']))
    assert scaled.tool_speed_m_s == nominal.tool_speed_m_s
    assert (scaled.tool_speed_scale, scaled.tool_speed_driven_m_s) == pytest.approx((1.5, 1.5))
    assert scaled.physics_key != nominal.physics_key
    assert scaled.scene_key == nominal.scene_key


def test_a_native_run_writes_its_identity(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                          ) -> None:
    """``dempath simulate``'s summary.json holds the identity of the scene it ran."""
    out = tmp_path / 'run'
    assert simulate_main(['tiny', '--out', str(out), '--quiet', '--cache-dir',
                          str(tmp_path / 'packings')]) == 0
    capsys.readouterr()
    summary = json.loads((out / 'summary.json').read_text())
    identity = run_identity(bundled_scene('tiny')).as_meta()
    assert {k: summary[k] for k in identity} == identity
    assert summary['engine'] == 'dempath'
