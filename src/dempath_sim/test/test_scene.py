"""Scene files: the shipped scenes load with the paper's values; bad input names the key."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest
import yaml

from dempath_sim.scene import (
    SCENES_DIR,
    SceneError,
    bundled_scene,
    list_bundled_scenes,
    load_scene,
    scene_from_dict,
)


def tiny_dict() -> dict[str, Any]:
    """The tiny scene as a plain mapping, with the mesh path made absolute."""
    data = yaml.safe_load((SCENES_DIR / 'tiny.yaml').read_text())
    return copy.deepcopy(data)


def error_of(data: dict[str, Any]) -> str:
    """The SceneError message for ``data``."""
    with pytest.raises(SceneError) as info:
        scene_from_dict(data, 'bad.yaml')
    return str(info.value)


def test_bundled_scenes_load() -> None:
    """Every shipped scene validates and names itself."""
    names = list_bundled_scenes()
    assert {'paper_1ms', 'paper_1_5ms', 'reduced_1ms', 'reduced_1_5ms', 'tiny'} <= set(names)
    for name in names:
        assert bundled_scene(name).name == name


def test_tiny_long_runs_the_chisel_past_the_marker_grid() -> None:
    """``tiny_long`` (tracking's longer test pass) is tiny with a longer bin and travel: its
    chisel ends 70 mm past the grid's last row, where tiny's stops inside the grid."""
    def end_past_grid(name: str) -> float:
        scene = bundled_scene(name)
        last_row = scene.markers.first_z_m + (scene.markers.columns - 1) \
            * scene.markers.spacing_z_m
        return scene.tool.start_z_m + scene.tool.travel_m - last_row

    assert end_past_grid('tiny_long') == pytest.approx(0.07)
    assert end_past_grid('tiny') < 0
    long, tiny = bundled_scene('tiny_long'), bundled_scene('tiny')
    assert (long.layers, long.tool.depth_m, long.markers) == (tiny.layers, tiny.tool.depth_m,
                                                            tiny.markers)


def test_paper_scene_has_table_values() -> None:
    """The paper scene carries Tables 2 and 6 and the paper's geometry."""
    scene = bundled_scene('paper_1ms')
    model = scene.physics_model()
    assert (scene.bin.width_x_m, scene.bin.length_z_m, scene.bin.height_y_m) == (1.0, 2.4, 1.02)
    assert [layer.diameter_m for layer in scene.layers] == [0.020, 0.004]
    assert model.particle_youngs_modulus_pa == pytest.approx(1.7e6)
    assert model.particle_poisson == 0.25 and model.tool_poisson == 0.30
    assert model.tool_youngs_modulus_pa == pytest.approx(2.1e11)
    assert model.tool_density_kg_m3 == 7800 and model.particle_density_kg_m3 == 1734
    pp, pt = model.particle_particle, model.particle_tool
    assert (pp.static_friction, pp.dynamic_friction, pp.rolling_resistance) == (0.71, 0.59, 0.26)
    assert (pt.static_friction, pt.dynamic_friction, pt.restitution) == (0.40, 0.30, 0.30)
    assert pp.restitution == 0.30 and pp.cohesion_energy_density_j_m3 == 0.0
    assert scene.tool.depth_m == 0.184 and scene.tool.settling_offset_m == -0.017
    assert scene.tool.travel_m == 1.2 and scene.tool.profile.name == 'paper_1ms'
    assert bundled_scene('paper_1_5ms').tool.profile.speed_m_s == 1.5


def test_misspelt_key_is_named_with_suggestion() -> None:
    """A misspelt key gives one SceneError naming it and the closest known key."""
    data = tiny_dict()
    data['tool']['depht_m'] = data['tool'].pop('depth_m')
    msg = error_of(data)
    assert 'tool.depht_m' in msg and "did you mean 'depth_m'" in msg


def test_wrong_unit_key_is_reported() -> None:
    """A key in millimetres is reported as a wrong unit with the SI key to use."""
    data = tiny_dict()
    data['tool']['depth_mm'] = 40
    del data['tool']['depth_m']
    msg = error_of(data)
    assert 'tool.depth_mm' in msg and 'wrong unit' in msg and "'depth_m'" in msg


def test_unit_in_value_is_reported() -> None:
    """A value carrying a unit string names the key and the unit it expects."""
    data = tiny_dict()
    data['bin']['width_x_m'] = '160 mm'
    msg = error_of(data)
    assert 'bin.width_x_m' in msg and 'expected a number in m' in msg


def test_out_of_range_values() -> None:
    """Out-of-range values name the key and the range."""
    data = tiny_dict()
    data['effects']['rolling_resistance']['coefficient'] = 3.0
    assert 'effects.rolling_resistance.coefficient' in error_of(data)
    data = tiny_dict()
    data['materials']['particles']['poisson_ratio'] = 0.7
    assert 'materials.particles.poisson_ratio' in error_of(data)
    data = tiny_dict()
    data['tool']['travel_m'] = 0.29
    assert 'tool.travel_m' in error_of(data)


def test_effect_errors() -> None:
    """Unknown effects, non-switchable effects off and dynamic > static friction are refused."""
    data = tiny_dict()
    data['effects']['cohesian'] = {'enabled': True}
    assert "did you mean 'cohesion'" in error_of(data)
    data = tiny_dict()
    data['effects']['restitution'] = {'enabled': False}
    assert 'cannot be switched off' in error_of(data)
    data = tiny_dict()
    data['effects']['tool_friction'] = {'static_friction': 0.2, 'dynamic_friction': 0.3}
    assert 'tool_friction.dynamic_friction' in error_of(data)


def test_bad_stl_path(tmp_path: Path) -> None:
    """A missing mesh file names tool.mesh and the path."""
    data = tiny_dict()
    data['tool']['mesh'] = str(tmp_path / 'nope.stl')
    msg = error_of(data)
    assert 'tool.mesh' in msg and 'nope.stl' in msg


def test_missing_file_and_bad_yaml(tmp_path: Path) -> None:
    """A missing file or broken YAML gives one SceneError naming the file."""
    with pytest.raises(SceneError, match='cannot read'):
        load_scene(tmp_path / 'absent.yaml')
    bad = tmp_path / 'bad.yaml'
    bad.write_text('name: [unclosed\n')
    with pytest.raises(SceneError, match='not valid YAML'):
        load_scene(bad)
    latin = tmp_path / 'latin1.yaml'
    latin.write_bytes('name: caf\xe9\n'.encode('latin-1'))  # not UTF-8: was a traceback
    with pytest.raises(SceneError, match=r'latin1.yaml: not a UTF-8 text file \(byte 0xe9'):
        load_scene(latin)


def test_overrides_switch_and_set() -> None:
    """Overrides set a parameter (turning its effect on) and switch effects off."""
    scene = bundled_scene('tiny')
    assert not scene.is_enabled('cohesion')
    changed = scene.with_overrides({'cohesion.energy_density_j_m3': 5e4},
                                   off=['tool_friction'], seed=7)
    model = changed.physics_model()
    assert changed.is_enabled('cohesion') and changed.seed == 7
    assert model.particle_particle.cohesion_energy_density_j_m3 == 5e4
    assert model.particle_tool.static_friction == 0.0
    with pytest.raises(SceneError, match=r'effects\.cohesion\.strength'):
        scene.with_overrides({'cohesion.strength': 1.0})


def test_profile_forms_agree() -> None:
    """An inline profile by distance equals one by acceleration; a mismatch is refused."""
    data = tiny_dict()
    data['tool']['profile'] = {'speed_m_s': 0.5, 'acceleration_m_s2': 2.5,
                               'steady_distance_m': 0.15}
    by_rate = scene_from_dict(data).tool.profile
    assert by_rate.acceleration_distance_m == pytest.approx(0.05)
    data['tool']['profile']['acceleration_distance_m'] = 0.2
    assert 'tool.profile.acceleration_distance_m' in error_of(data)


def test_bad_stl_content(tmp_path: Path) -> None:
    """A truncated STL names tool.mesh and says the STL is bad."""
    bad = tmp_path / 'broken.stl'
    bad.write_bytes(b'\x00' * 80 + (5).to_bytes(4, 'little') + b'\x00' * 20)
    data = tiny_dict()
    data['tool']['mesh'] = str(bad)
    msg = error_of(data)
    assert 'tool.mesh' in msg and 'bad STL' in msg
