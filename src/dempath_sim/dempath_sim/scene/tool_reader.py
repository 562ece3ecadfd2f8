"""The ``tool`` section of a scene file: its mesh, depth, placement and speed profile.

Read by :mod:`dempath_sim.scene.loader`; every wrong value raises one SceneError naming the key.
"""

from __future__ import annotations

from pathlib import Path

from dempath_sim.engine.solid import open_edges
from dempath_sim.engine.stl import read_stl
from dempath_sim.errors import GeometryError
from dempath_sim.scene import profiles
from dempath_sim.scene import spec as records
from dempath_sim.scene._reader import Reader

DATA_DIR = Path(__file__).resolve().parents[1] / 'data'
BUILTIN_PREFIX = 'builtin:'


def resolve_mesh(value: str, r: Reader, base_dir: Path | None) -> Path:
    """The STL file a ``mesh`` value names (``builtin:NAME`` from the package data, else relative
    to the scene file), checked to exist and to read as STL."""
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


def read_profile(r: Reader) -> profiles.SpeedProfile:
    """The tool's speed profile: a preset's name or its speed, phases and steady distance."""
    raw = r.raw('profile')
    if isinstance(raw, str):
        r.text('profile', choices=sorted(profiles.PRESETS))
        return profiles.PRESETS[raw]
    p = r.section('profile')
    speed = p.number('speed_m_s', 0.0, 20.0, low_open=True)
    steady = p.number('steady_distance_m', 0.0, 1000.0)
    accel = phase_rate(p, 'acceleration', speed)
    decel = phase_rate(p, 'deceleration', speed) if (
        p.has('deceleration_m_s2') or p.has('deceleration_distance_m')) else accel
    name = p.text('name', 'custom')
    p.finish()
    return profiles.SpeedProfile(speed, accel, decel, steady, name)


def phase_rate(p: Reader, phase: str, speed: float) -> float:
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


def read_tool(r: Reader, base_dir: Path | None, bin_spec: records.BinSpec) -> records.ToolSpec:
    """The ``tool`` section, checked against the bin (travel inside it, a closed mesh to carve)."""
    spec = records.ToolSpec(
        mesh=resolve_mesh(r.text('mesh'), r, base_dir),
        scale=r.number('scale', 0.0, 100.0, 1.0, low_open=True),
        depth_m=r.number('depth_m', 0.0, bin_spec.height_y_m, low_open=True),
        depth_reference=r.text('depth_reference', 'settled_surface',
                               ('settled_surface', 'nominal_surface')),
        settling_offset_m=r.number('settling_offset_m', -1.0, 1.0, 0.0),
        x_m=r.number('x_m', -bin_spec.width_x_m / 2, bin_spec.width_x_m / 2, 0.0),
        start_z_m=r.number('start_z_m', 0.0, bin_spec.length_z_m),
        profile=read_profile(r),
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
