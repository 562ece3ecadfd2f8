"""The bed's sections of a scene file: layers and their size distributions, markers, the fill.

Read by :mod:`dempath_sim.scene.loader`; every wrong value raises one SceneError naming the key.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from dempath_sim.scene import spec as records
from dempath_sim.scene._reader import Reader
from dempath_sim.scene.spec import MARKER_PICKS


def read_distribution(r: Reader) -> records.SizeDistribution:
    """A layer's grain sizes: mono, uniform with a spread, or discrete diameters by mass."""
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


def read_layers(raw: Any, source: str) -> tuple[records.LayerSpec, ...]:
    """The layers, bottom to top, each at least one grain thick."""
    if not isinstance(raw, list) or not raw:
        Reader.fail_at('layers', source, 'expected a non-empty list of layers (bottom to top)')
    layers = []
    for i, item in enumerate(raw):
        r = Reader(item, f'layers[{i}]', source)
        layers.append(records.LayerSpec(
            name=r.text('name', f'layer{i}'),
            diameter_m=r.number('diameter_m', 1e-5, 1.0, low_open=True),
            thickness_m=r.number('thickness_m', 0.0, 100.0, low_open=True),
            distribution=read_distribution(r.section('distribution', required=False)),
            coarse_grained=r.flag('coarse_grained', True)))
        r.finish()
        if layers[-1].thickness_m < layers[-1].diameter_m:
            r.fail('thickness_m', 'is thinner than one particle diameter')
    return tuple(layers)


def read_markers(r: Reader, bin_spec: records.BinSpec) -> records.MarkerSpec:
    """The marker grid (rows x columns), inside the bin, and how its grains are picked."""
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


def read_packing_path(f: Reader, base_dir: Path | None) -> Path | None:
    """An imported packing file (relative to the scene file), or None to pour one."""
    if not f.has('packing'):
        return None
    path = Path(f.text('packing')).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    if not path.is_file():
        f.fail('packing', f'packing file {str(path)!r} does not exist')
    return path


def read_fill(f: Reader, base_dir: Path | None) -> records.FillSpec:
    """How the bed is made: pour, target density, settling and its cache."""
    return records.FillSpec(
        f.maybe_number('bulk_density_target_kg_m3', 1.0, 30000.0),
        f.number('tolerance', 0.0, 1.0, 0.02, low_open=True),
        f.number('settle_speed_m_s', 0.0, 10.0, 0.02, low_open=True),
        f.number('max_settle_time_s', 0.0, 100.0, 3.0, low_open=True),
        f.flag('cache', True), f.number('friction_scale', 0.0, 1.0, 1.0),
        f.number('pour_solid_fraction', 0.05, 0.45, 0.35),
        f.text('physics', 'scene', ('scene', 'run')),
        read_packing_path(f, base_dir), f.text('count', 'volume', records.FILL_COUNTS))
