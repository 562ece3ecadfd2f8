"""The effects library's candidates as cross-engine variants (validation.effect_variants)."""

from __future__ import annotations

import pytest

from dempath_diagnose.library import simulator, store
from dempath_sim.scene import bundled_scene
from dempath_sim.validation.effect_variants import (
    VARIANTS,
    variant_overrides,
    variant_scene,
)


def test_variants_use_the_signature_librarys_upper_strengths() -> None:
    """The cross-engine variants are the strengths the diagnosis library runs (one table,
    ``dempath_sim.effects.candidates``), so a signature checked across engines is one the
    diagnosis uses: every candidate of the library is a variant, at the library's largest
    strength."""
    scene = bundled_scene('reduced_1ms')
    assert set(VARIANTS) == {'base', *simulator.LIBRARY_CANDIDATES}
    for cand in simulator.scene_candidates(scene):
        upper, _ = variant_overrides(scene, cand.name)
        lower, _ = variant_overrides(scene, cand.name, 'lower')
        runs = store.strengths(cand, 2)
        assert upper[f'{cand.name}.{cand.parameter}'] == pytest.approx(max(runs))
        assert lower[f'{cand.name}.{cand.parameter}'] == pytest.approx(min(runs))
    with pytest.raises(ValueError, match="strength: 'middle' is not one of upper, lower"):
        variant_overrides(scene, 'cohesion', 'middle')


def test_reduced_scene_variants() -> None:
    """Cohesion (off) comes on at 5x its default between grains only; rolling resistance (on)
    and the parameters move x1.5 with their linked values, Young's modulus x3."""
    scene = bundled_scene('reduced_1ms')
    values, on = variant_overrides(scene, 'cohesion')
    assert on == ('cohesion',)
    assert values == {'cohesion.energy_density_j_m3': pytest.approx(1.0e5),
                      'cohesion.boundary_fraction': 0.0}
    values, on = variant_overrides(scene, 'rolling_resistance')
    assert on == ()
    assert values['rolling_resistance.coefficient'] == pytest.approx(1.5 * 0.26)
    values, _ = variant_overrides(scene, 'particle_friction')
    assert values['particle_friction.static_friction'] == pytest.approx(1.5 * 0.71)
    assert values['particle_friction.dynamic_friction'] == pytest.approx(1.5 * 0.59)
    values, _ = variant_overrides(scene, 'youngs_modulus')
    assert values['youngs_modulus.youngs_modulus_pa'] == pytest.approx(3 * 1.7e6)
    assert variant_overrides(scene, 'base') == ({}, ())
    with pytest.raises(ValueError, match="'friction' is not one of"):
        variant_overrides(scene, 'friction')


@pytest.mark.parametrize('name', VARIANTS)
def test_a_variant_keeps_the_scenes_bed(name: str) -> None:
    """Every variant starts from the bed poured with the scene file's effects (one pour per
    seed for all variants, on both engines) and changes the run's physics only."""
    scene = bundled_scene('reduced_1ms')
    variant = variant_scene(scene, name)
    assert variant.bed_model() == scene.bed_model()
    assert (variant.physics_model() == scene.physics_model()) == (name == 'base')
