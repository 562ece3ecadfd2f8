"""The effect registry: discovery from modules, ranges, on/off semantics, the effects command."""

from __future__ import annotations

import json
import pkgutil

import pytest

import dempath_sim.effects as effects_pkg
from dempath_sim.cli import effect_rows, effects_main
from dempath_sim.effects import all_effects, get_effect
from dempath_sim.scene import bundled_scene

REQUIRED = {'rolling_resistance', 'cohesion', 'tool_friction', 'wall_friction',
            'particle_friction', 'restitution', 'youngs_modulus', 'particle_size', 'tool_speed'}


def test_registry_is_discovered_from_modules() -> None:
    """Every public module of the package but base and the candidate table is one effect,
    named like the module."""
    modules = {m.name for m in pkgutil.iter_modules(effects_pkg.__path__)
               if not m.name.startswith('_') and m.name not in ('base', 'candidates')}
    assert set(all_effects()) == modules
    assert modules >= REQUIRED


def test_parameters_are_ranged_with_units() -> None:
    """Every parameter has a unit, low <= default <= high and a doc line."""
    for effect in all_effects().values():
        assert effect.description and effect.parameters
        for p in effect.parameters:
            assert p.unit and p.doc and p.low <= p.default <= p.high
    with pytest.raises(KeyError, match='unknown effect'):
        get_effect('gravity_waves')


def test_on_off_semantics() -> None:
    """Switching an effect off removes exactly its physics from the model."""
    scene = bundled_scene('paper_1ms')
    base = scene.physics_model()
    no_roll = scene.with_overrides(off=['rolling_resistance']).physics_model()
    for pair in ('particle_particle', 'particle_tool', 'particle_wall'):
        assert getattr(no_roll, pair).rolling_resistance == 0.0
        assert getattr(base, pair).rolling_resistance == 0.26
    no_tool = scene.with_overrides(off=['tool_friction']).physics_model()
    assert no_tool.particle_tool.static_friction == 0.0
    assert no_tool.particle_wall == base.particle_wall
    assert no_tool.particle_particle == base.particle_particle
    wet = scene.with_overrides({'cohesion.energy_density_j_m3': 3e4}).physics_model()
    assert wet.particle_particle.cohesion_energy_density_j_m3 == 3e4
    assert wet.particle_tool.cohesion_energy_density_j_m3 == 0.0


def test_model_parameter_effects() -> None:
    """Young's modulus, restitution, coarse grain and speed scale reach the model."""
    scene = bundled_scene('tiny').with_overrides({
        'youngs_modulus.youngs_modulus_pa': 5e6, 'restitution.particle_boundary': 0.5,
        'particle_size.coarse_grain': 2.0, 'tool_speed.speed_scale': 1.5})
    model = scene.physics_model()
    assert model.particle_youngs_modulus_pa == 5e6
    assert model.particle_tool.restitution == 0.5 and model.particle_particle.restitution == 0.3
    assert model.coarse_grain == 2.0 and model.speed_scale == 1.5


def test_effect_rows_and_command(capsys: pytest.CaptureFixture[str]) -> None:
    """`dempath effects tiny --json` lists every parameter with the scene's state."""
    rows = effect_rows(bundled_scene('tiny'))
    assert {r['effect'] for r in rows} == set(all_effects())
    assert effects_main(['tiny', '--json']) == 0
    printed = json.loads(capsys.readouterr().out)
    cohesion = [r for r in printed if r['effect'] == 'cohesion']
    assert cohesion and not cohesion[0]['enabled'] and cohesion[0]['unit'] == 'J/m^3'
    assert effects_main([]) == 0
    table = capsys.readouterr().out
    assert 'rolling_resistance' in table and 'tool_speed' in table
    assert effects_main(['no_such_scene']) == 1
    assert 'error: no_such_scene' in capsys.readouterr().err
