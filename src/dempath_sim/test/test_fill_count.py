"""``fill.count``: pouring the number of grains that brings the settled surface to Y = 0."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
import yaml

from dempath_sim.errors import SceneError
from dempath_sim.runs.bed import fill_bed, packing_key
from dempath_sim.runs.physics import build_params
from dempath_sim.scene import bundled_scene, load_scene
from dempath_sim.scene.loader import SCENES_DIR


def test_count_is_read_and_a_bad_value_is_one_error(tmp_path: Path) -> None:
    """``fill.count`` takes volume or surface; anything else names the key and the choices."""
    raw = yaml.safe_load((SCENES_DIR / 'tiny.yaml').read_text())
    raw['fill']['count'] = 'surface'
    path = tmp_path / 'scene.yaml'
    path.write_text(yaml.safe_dump(raw))
    assert load_scene(path).fill.count == 'surface'
    raw['fill']['count'] = 'level'
    path.write_text(yaml.safe_dump(raw))
    with pytest.raises(SceneError, match=r"fill.count.*'level' is not one of volume, surface"):
        load_scene(path)


def test_default_count_keeps_the_packing_keys() -> None:
    """The option at its default leaves every cache key as it was; ``surface`` changes it."""
    scene = bundled_scene('tiny')
    model = scene.physics_model()
    surface = replace(scene, fill=replace(scene.fill, count='surface'))
    assert scene.fill.count == 'volume'
    assert packing_key(surface, model) != packing_key(scene, model)


@pytest.mark.slow
def test_surface_count_brings_the_surface_to_nominal(tmp_path: Path) -> None:
    """With ``count: surface`` the settled surface ends within tolerance x thickness of Y = 0
    and the density target is still met; the volume count leaves it further off."""
    scene = bundled_scene('tiny')
    fill = replace(scene.fill, bulk_density_target_kg_m3=1020.0, tolerance=0.05)
    by_volume = replace(scene, fill=fill)
    by_surface = replace(scene, fill=replace(fill, count='surface'))
    model = scene.bed_model()
    _, volume = fill_bed(by_volume, model, build_params(by_volume, model), tmp_path)
    state, surface = fill_bed(by_surface, model, build_params(by_surface, model), tmp_path)
    limit = 0.05 * scene.bed_thickness_m
    assert abs(surface.surface_height_m) <= limit
    assert surface.within_tolerance and surface.n_particles == state.n
    if abs(volume.surface_height_m) > limit:  # the tiny bin's count was off: it was rescaled
        assert surface.count_scale != 1.0 and surface.n_particles != volume.n_particles
