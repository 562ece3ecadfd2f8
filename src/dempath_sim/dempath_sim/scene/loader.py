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

from dataclasses import replace
from pathlib import Path
from typing import Any

import yaml

from dempath_sim.engine.params import (
    CONTACT_FORMS,
    COULOMB_LIMITS,
    DEFAULT_MAX_OVERLAP_FRACTION,
)
from dempath_sim.engine.solid import open_edges
from dempath_sim.engine.stl import read_stl
from dempath_sim.errors import GeometryError, SceneError
from dempath_sim.scene import profiles
from dempath_sim.scene import spec as records
from dempath_sim.scene._reader import Reader
from dempath_sim.scene.spec import MARKER_PICKS, SceneSpec, read_effects

__all__ = ['bundled_scene', 'list_bundled_scenes', 'load_scene', 'parse_overrides',
           'resolve_scene', 'scene_from_dict']

DATA_DIR = Path(__file__).resolve().parents[1] / 'data'
SCENES_DIR = DATA_DIR / 'scenes'
BUILTIN_PREFIX = 'builtin:'


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


def _resolve_mesh(value: str, r: Reader, base_dir: Path | None) -> Path:
    if value.startswith(BUILTIN_PREFIX):
        path = DATA_DIR / value[len(BUILTIN_PREFIX):]
    else:
        path = Path(value).expanduser()
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
    if not path.is_file():
        r.fail('mesh', f'STL file {str(path)!r} does not exist')
    if path.suffix.lower() != '.stl':
        r.fail('mesh', f'{str(path)!r} is not an .stl file')
    try:
        read_stl(path)
    except GeometryError as err:
        r.fail('mesh', f'bad STL: {err}')
    return path


def _read_profile(r: Reader) -> profiles.SpeedProfile:
    raw = r.raw('profile')
    if isinstance(raw, str):
        r.text('profile', choices=sorted(profiles.PRESETS))
        return profiles.PRESETS[raw]
    p = r.section('profile')
    speed = p.number('speed_m_s', 0.0, 20.0, low_open=True)
    steady = p.number('steady_distance_m', 0.0, 1000.0)
    accel = _phase(p, 'acceleration', speed)
    decel = _phase(p, 'deceleration', speed) if (
        p.has('deceleration_m_s2') or p.has('deceleration_distance_m')) else accel
    name = p.text('name', 'custom')
    p.finish()
    return profiles.SpeedProfile(speed, accel, decel, steady, name)


def _phase(p: Reader, phase: str, speed: float) -> float:
    """Acceleration magnitude [m/s^2] from ``<phase>_m_s2`` or ``<phase>_distance_m``."""
    rate_key, dist_key = f'{phase}_m_s2', f'{phase}_distance_m'
    rate = p.maybe_number(rate_key, 0.0, 1000.0, low_open=True)
    dist = p.maybe_number(dist_key, 0.0, 1000.0, low_open=True)
    if rate is None and dist is None:
        p.fail(rate_key, f'give {rate_key} or {dist_key}')
    if dist is not None:
        from_dist = speed**2 / (2.0 * dist)
        if rate is not None and abs(from_dist - rate) > 0.01 * rate:
            p.fail(dist_key, f'{dist} m does not match {rate_key} {rate} m/s^2 at '
                             f'{speed} m/s (v^2/2a = {speed**2 / (2 * rate):.4g} m)')
        return rate if rate is not None else from_dist
    assert rate is not None
    return rate


def _read_tool(r: Reader, base_dir: Path | None, bin_spec: records.BinSpec) -> records.ToolSpec:
    spec = records.ToolSpec(
        mesh=_resolve_mesh(r.text('mesh'), r, base_dir),
        scale=r.number('scale', 0.0, 100.0, 1.0, low_open=True),
        depth_m=r.number('depth_m', 0.0, bin_spec.height_y_m, low_open=True),
        depth_reference=r.text('depth_reference', 'settled_surface',
                               ('settled_surface', 'nominal_surface')),
        settling_offset_m=r.number('settling_offset_m', -1.0, 1.0, 0.0),
        x_m=r.number('x_m', -bin_spec.width_x_m / 2, bin_spec.width_x_m / 2, 0.0),
        start_z_m=r.number('start_z_m', 0.0, bin_spec.length_z_m),
        profile=_read_profile(r),
        profile_offset_m=r.number('profile_offset_m', 0.0, 1000.0, 0.0),
        travel_m=r.number('travel_m', 0.0, bin_spec.length_z_m, low_open=True),
        placement=r.text('placement', 'carve', ('carve', 'slot', 'poured')),
        settle_s=r.number('settle_s', 0.0, 10.0, 0.06))
    bad = open_edges(read_stl(spec.mesh)) if spec.placement != 'slot' else 0
    if bad:
        r.fail('mesh', f'{str(spec.mesh)!r} is not a closed mesh ({bad} open or inconsistently '
                       'oriented edges), so the carve cannot tell inside from outside; close '
                       'it or set tool.placement: slot')
    if spec.placement == 'poured' and spec.depth_reference != 'nominal_surface':
        r.fail('placement', 'poured places the tool before the bed settles, so its depth must '
                            'be below the nominal surface: set tool.depth_reference: '
                            'nominal_surface')
    if spec.start_z_m + spec.travel_m > bin_spec.length_z_m:
        r.fail('travel_m', f'start_z_m + travel_m = {spec.start_z_m + spec.travel_m:g} m '
                           f'runs past the bin end at {bin_spec.length_z_m:g} m')
    if spec.profile_offset_m + spec.travel_m > spec.profile.total_distance_m + 1e-9:
        r.fail('travel_m', f'profile_offset_m + travel_m exceeds the profile length '
                           f'{spec.profile.total_distance_m:g} m')
    r.finish()
    return spec


def _read_distribution(r: Reader) -> records.SizeDistribution:
    kind = r.text('kind', 'mono', ('mono', 'uniform', 'discrete'))
    dist = records.SizeDistribution(kind=kind, spread=r.number('spread', 0.0, 0.5, 0.0))
    if kind == 'discrete':
        n = len(r.raw('diameters_m'))
        dist = replace(dist, diameters_m=r.vector('diameters_m', n, 1e-5, 1.0),
                       mass_fractions=r.vector('mass_fractions', n, 0.0, 1.0))
        if sum(dist.mass_fractions) <= 0.0:
            r.fail('mass_fractions', 'must not all be zero')
    r.finish()
    return dist


def _read_layers(raw: Any, source: str) -> tuple[records.LayerSpec, ...]:
    if not isinstance(raw, list) or not raw:
        Reader.fail_at('layers', source, 'expected a non-empty list of layers (bottom to top)')
    layers = []
    for i, item in enumerate(raw):
        r = Reader(item, f'layers[{i}]', source)
        layers.append(records.LayerSpec(
            name=r.text('name', f'layer{i}'),
            diameter_m=r.number('diameter_m', 1e-5, 1.0, low_open=True),
            thickness_m=r.number('thickness_m', 0.0, 100.0, low_open=True),
            distribution=_read_distribution(r.section('distribution', required=False)),
            coarse_grained=r.flag('coarse_grained', True)))
        r.finish()
        if layers[-1].thickness_m < layers[-1].diameter_m:
            r.fail('thickness_m', 'is thinner than one particle diameter')
    return tuple(layers)


def _read_markers(r: Reader, bin_spec: records.BinSpec) -> records.MarkerSpec:
    spec = records.MarkerSpec(
        rows=r.integer('rows', 1, 20, 3), columns=r.integer('columns', 1, 50, 5),
        spacing_x_m=r.number('spacing_x_m', 0.0, bin_spec.width_x_m, 0.05, low_open=True),
        spacing_z_m=r.number('spacing_z_m', 0.0, bin_spec.length_z_m, 0.05, low_open=True),
        first_z_m=r.number('first_z_m', 0.0, bin_spec.length_z_m),
        x_m=r.number('x_m', -bin_spec.width_x_m / 2, bin_spec.width_x_m / 2, 0.0),
        side=r.integer('side', -1, 1, 1),
        cube_size_m=r.vector('cube_size_m', 3, 1e-4, 1.0, (0.03, 0.02, 0.01)),  # type: ignore[arg-type]
        pick=r.text('pick', 'exposed', MARKER_PICKS))
    if spec.side == 0:
        r.fail('side', 'must be +1 or -1 (the side of the axis the other rows lie on)')
    last_z = spec.first_z_m + (spec.columns - 1) * spec.spacing_z_m
    if last_z > bin_spec.length_z_m:
        r.fail('first_z_m', f'the grid reaches Z = {last_z:g} m, past the bin end')
    r.finish()
    return spec


def _read_packing_path(f: Reader, base_dir: Path | None) -> Path | None:
    if not f.has('packing'):
        return None
    path = Path(f.text('packing')).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    if not path.is_file():
        f.fail('packing', f'packing file {str(path)!r} does not exist')
    return path


def _read_fill(f: Reader, base_dir: Path | None) -> records.FillSpec:
    return records.FillSpec(
        f.maybe_number('bulk_density_target_kg_m3', 1.0, 30000.0),
        f.number('tolerance', 0.0, 1.0, 0.02, low_open=True),
        f.number('settle_speed_m_s', 0.0, 10.0, 0.02, low_open=True),
        f.number('max_settle_time_s', 0.0, 100.0, 3.0, low_open=True),
        f.flag('cache', True), f.number('friction_scale', 0.0, 1.0, 1.0),
        f.number('pour_solid_fraction', 0.05, 0.45, 0.35),
        f.text('physics', 'scene', ('scene', 'run')),
        _read_packing_path(f, base_dir), f.text('count', 'volume', records.FILL_COUNTS))


def _read_sections(r: Reader, source: str, base_dir: Path | None) -> dict[str, Any]:
    bin_r = r.section('bin')
    bin_spec = records.BinSpec(bin_r.number('width_x_m', 0.0, 100.0, low_open=True),
                               bin_r.number('length_z_m', 0.0, 1000.0, low_open=True),
                               bin_r.number('height_y_m', 0.0, 100.0, low_open=True))
    bin_r.finish()
    f, o, s = r.section('fill', False), r.section('output', False), r.section('sim', False)
    out: dict[str, Any] = dict(
        bin=bin_spec, layers=_read_layers(r.raw('layers'), source),
        materials=_read_materials(r.section('materials')),
        effects=read_effects(r.section('effects', required=False)),
        tool=_read_tool(r.section('tool'), base_dir, bin_spec),
        markers=_read_markers(r.section('markers'), bin_spec),
        fill=_read_fill(f, base_dir),
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
