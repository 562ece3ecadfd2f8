"""Scene files: the soil bin, its layers, materials, effects, tool, markers and outputs.

A scene is a YAML file read by :func:`load_scene` into a frozen :class:`SceneSpec`. Units are SI
and named by each key's suffix: ``_m`` metres, ``_s`` seconds, ``_m_s`` m/s, ``_m_s2`` m/s^2,
``_pa`` pascal, ``_kg_m3`` kg/m^3, ``_j_m3`` J/m^3; keys without a suffix are dimensionless. A
wrong key, a wrong unit (``depth_mm``, ``'184 mm'``) or a value outside its physical range
raises one :class:`SceneError` naming the file and the key. Frame of the paper: X lateral,
Y up, Z direction of travel; origin on the undisturbed sand surface on the tool axis, Z = 0 at
the bin's start wall. The bin spans X in [-width/2, width/2], Z in [0, length] and Y from
-(sum of layer thicknesses) to height - (sum of layer thicknesses).

Layout (see ``data/scenes/*.yaml`` for complete files)::

    name: paper_1ms
    seed: 1                                  # packing seed
    bin: {width_x_m: 1.0, length_z_m: 2.4, height_y_m: 1.02}
    layers:                                  # bottom to top
      - {name: base, diameter_m: 0.020, thickness_m: 0.50}
      - {name: top, diameter_m: 0.004, thickness_m: 0.26,
         distribution: {kind: uniform, spread: 0.1}}
    materials:
      particles: {density_kg_m3: 1734, poisson_ratio: 0.25}
      tool: {density_kg_m3: 7800, youngs_modulus_pa: 2.1e11, poisson_ratio: 0.30}
      walls: {density_kg_m3: 7800, youngs_modulus_pa: 2.1e11, poisson_ratio: 0.30}
    effects:                                 # see `dempath effects`
      rolling_resistance: {enabled: true, coefficient: 0.26}
      cohesion: {enabled: false}
    tool: {mesh: builtin:chisel.stl, depth_m: 0.184, start_z_m: 0.3, travel_m: 1.2,
           profile: paper_1ms}
    markers: {first_z_m: 1.0}
    fill: {bulk_density_target_kg_m3: 1040}
    output: {interval_s: 0.01, snapshot_interval_s: 0.1}
    sim: {time_step_s: null, rayleigh_safety: 0.2}
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from dempath_sim.engine.params import (
    CONTACT_FORMS,
    COULOMB_LIMITS,
    DEFAULT_MAX_OVERLAP_FRACTION,
)
from dempath_sim.errors import SceneError
from dempath_sim.scene import spec as records
from dempath_sim.scene._reader import Reader
from dempath_sim.scene.bed_reader import read_fill, read_layers, read_markers
from dempath_sim.scene.spec import SceneSpec, read_effects
from dempath_sim.scene.tool_reader import BUILTIN_PREFIX, DATA_DIR, read_tool

__all__ = ['bundled_scene', 'list_bundled_scenes', 'load_scene', 'parse_overrides',
           'resolve_scene', 'scene_from_dict']

SCENES_DIR = DATA_DIR / 'scenes'


def _read_material(r: Reader, needs_modulus: bool) -> records.MaterialSpec:
    spec = records.MaterialSpec(
        density_kg_m3=r.number('density_kg_m3', 1.0, 30000.0, low_open=True),
        poisson_ratio=r.number('poisson_ratio', 0.0, 0.49),
        youngs_modulus_pa=(r.number('youngs_modulus_pa', 1e4, 1e13) if needs_modulus
                           else None))
    r.finish()
    return spec


def _read_materials(r: Reader) -> dict[str, records.MaterialSpec]:
    out = {'particles': _read_material(r.section('particles'), False),
           'tool': _read_material(r.section('tool'), True),
           'walls': _read_material(r.section('walls'), True)}
    r.finish()
    return out


def _read_sections(r: Reader, source: str, base_dir: Path | None) -> dict[str, Any]:
    bin_r = r.section('bin')
    bin_spec = records.BinSpec(bin_r.number('width_x_m', 0.0, 100.0, low_open=True),
                               bin_r.number('length_z_m', 0.0, 1000.0, low_open=True),
                               bin_r.number('height_y_m', 0.0, 100.0, low_open=True))
    bin_r.finish()
    f, o, s = r.section('fill', False), r.section('output', False), r.section('sim', False)
    out: dict[str, Any] = dict(
        bin=bin_spec, layers=read_layers(r.raw('layers'), source),
        materials=_read_materials(r.section('materials')),
        effects=read_effects(r.section('effects', required=False)),
        tool=read_tool(r.section('tool'), base_dir, bin_spec),
        markers=read_markers(r.section('markers'), bin_spec),
        fill=read_fill(f, base_dir),
        output=records.OutputSpec(
            o.number('interval_s', 0.0, 10.0, 0.01, low_open=True),
            o.number('snapshot_interval_s', 0.0, 100.0, 0.1, low_open=True),
            o.flag('candidates', True)),
        sim=records.NumericsSpec(
            s.maybe_number('time_step_s', 0.0, 0.1, low_open=True),
            s.number('rayleigh_safety', 0.0, 1.0, 0.2, low_open=True),
            s.number('max_overlap_fraction', 0.0, 1.0, DEFAULT_MAX_OVERLAP_FRACTION,
                     low_open=True),
            s.text('coulomb_limit', 'total', choices=COULOMB_LIMITS),
            s.text('contact_forms', 'dempath', choices=CONTACT_FORMS),
            s.flag('sleep', False),
            s.number('sleep_scale', 0.0, 1000.0, 1.0, low_open=True)))
    for sub in (f, o, s):
        sub.finish()
    return out


def scene_from_dict(data: Any, source: str = '<dict>',
                    base_dir: Path | None = None) -> SceneSpec:
    """Validate a scene mapping (as loaded from YAML) into a SceneSpec.

    Args:
        data: The parsed YAML document.
        source: Name of the file for messages.
        base_dir: Directory that relative mesh paths are resolved against.

    Raises:
        SceneError: A wrong key, unit, type or value, naming the key.
    """
    r = Reader(data, '', source)
    head: dict[str, Any] = dict(name=r.text('name'), description=r.text('description', ''),
                seed=r.integer('seed', 0, 2**31 - 1, 0))
    sections = _read_sections(r, source, base_dir)
    r.finish()
    if sections['bin'].height_y_m <= sum(x.thickness_m for x in sections['layers']):
        Reader.fail_at('bin.height_y_m', source, 'the walls must be higher than the layers')
    return SceneSpec(**head, **sections, source=source, bed_effects=sections['effects'])


def load_scene(path: str | Path) -> SceneSpec:
    """Read and validate a scene file; ``builtin:NAME`` loads a bundled scene.

    Raises:
        SceneError: The file is missing or not YAML, or a key, unit or value is wrong.
    """
    text_path = str(path)
    if text_path.startswith(BUILTIN_PREFIX):
        return bundled_scene(text_path[len(BUILTIN_PREFIX):])
    file = Path(path)
    try:
        data = yaml.safe_load(file.read_text(encoding='utf-8'))
    except OSError as err:
        raise SceneError(f'{file}: cannot read scene file ({err.strerror})') from err
    except UnicodeDecodeError as err:
        raise SceneError(f'{file}: not a UTF-8 text file (byte 0x{err.object[err.start]:02x} '
                         f'at offset {err.start}); save the scene as UTF-8') from None
    except yaml.YAMLError as err:
        raise SceneError(f'{file}: not valid YAML ({err})') from err
    return scene_from_dict(data, str(file), file.resolve().parent)


def list_bundled_scenes() -> list[str]:
    """Names of the scenes shipped in ``dempath_sim/data/scenes``."""
    return sorted(p.stem for p in SCENES_DIR.glob('*.yaml'))


def bundled_scene(name: str) -> SceneSpec:
    """Load a shipped scene by name (``paper_1ms``, ``reduced_1ms``, ``tiny``...)."""
    path = SCENES_DIR / f'{name}.yaml'
    if not path.is_file():
        raise SceneError(f'{name}: no bundled scene of that name; known: '
                         f'{", ".join(list_bundled_scenes())}')
    return load_scene(path)


def resolve_scene(text: str) -> SceneSpec:
    """Load a scene file or a shipped scene (``reduced_1ms``, ``builtin:reduced_1ms``)."""
    path = Path(text)
    if text.startswith(BUILTIN_PREFIX):
        return bundled_scene(text.removeprefix(BUILTIN_PREFIX))
    if path.is_file() or path.suffix in {'.yaml', '.yml'} or '/' in text:
        return load_scene(path)
    if text in list_bundled_scenes():
        return bundled_scene(text)
    msg = (f'{text}: neither a scene file nor a shipped scene; shipped: '
           f'{", ".join(list_bundled_scenes())}')
    raise SceneError(msg)


def parse_overrides(items: list[str]) -> dict[str, float]:
    """``['cohesion.energy_density_j_m3=5e4']`` -> ``{'cohesion.energy_density_j_m3': 5e4}``."""
    out = {}
    for item in items:
        key, _, value = item.partition('=')
        try:
            number = float(value)
        except ValueError:
            number = None
        if number is None or '.' not in key:
            raise SceneError(f'--effect {item}: expected EFFECT.PARAMETER=NUMBER')
        out[key.strip()] = number
    return out
