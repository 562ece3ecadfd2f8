"""Model trajectories from other DEM tools: LIGGGHTS dumps and mapped CSV exports (EDEM, Rocky).

A user's own model run rarely comes in dempath's ``t,id,x,y,z`` shape. Two foreign forms are read
into the same :class:`~dempath_compare.records.Track` list as dempath's own CSV:

- a LIGGGHTS (or LAMMPS) ``dump custom`` text file with at least ``id x y z`` columns: its frames
  carry step numbers, so the mapping must give the time step ``dt_s`` (and ``start_step``, the
  step at which the tool starts to move, when the dump does not start there);
- a long CSV table (one row per particle and time), as EDEM's and Rocky's particle exports are
  written, with its own column names, units and axes.

An :class:`ExportMapping` (a small YAML file, ``--model-map``) says how to read either: which
column is the time, the particle id and each coordinate, the units (``m``/``mm``, ``s``/``ms``),
which signed source axis is the paper's X (lateral), Y (up) and Z (tool travel), the origin (the
undisturbed surface above the tool's start, in the source frame after units) and the time at
which the tool starts to move. Example (a Z-up export in millimetres, the tool along +X)::

    format: csv
    columns: {t: 'Time', id: 'ID', x: 'Position X', y: 'Position Y', z: 'Position Z'}
    length_unit: mm
    time_unit: s
    axes: [y, z, x]          # paper X = source y, paper Y = source z, paper Z = source x
    origin: [0.0, 0.0, 0.1]  # [m], in paper axes
    tool_start_s: 0.5
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath.errors import DumpError
from dempath_compare.errors import InputError
from dempath_compare.loaders import read_csv_columns
from dempath_compare.records import Track
from dempath_compare.runinfo import run_info

F64 = NDArray[np.float64]

LENGTH_UNITS = {'m': 1.0, 'mm': 1e-3, 'cm': 1e-2}
TIME_UNITS = {'s': 1.0, 'ms': 1e-3}
FORMATS = ('csv', 'liggghts')
DEFAULT_COLUMNS = {'t': 't', 'id': 'id', 'x': 'x', 'y': 'y', 'z': 'z'}


def _bad(field_name: str, value: object, why: str) -> InputError:
    return InputError(f'model map: {field_name} = {value!r}: {why}')


@dataclass(frozen=True)
class ExportMapping:
    """How a foreign model export maps onto dempath's tracks (paper frame, SI units).

    Attributes:
        format: ``csv`` (a long table, one row per particle and time) or ``liggghts`` (a
            ``dump custom`` text file).
        columns: dempath name (``t``, ``id``, ``x``, ``y``, ``z``) -> the file's column name
            (case-insensitive; a dump has no time column, its steps are used).
        length_unit: Unit of the positions: ``m``, ``cm`` or ``mm``.
        time_unit: Unit of the time column: ``s`` or ``ms``.
        axes: The signed source axis that is the paper's X (lateral), Y (up), Z (tool travel),
            e.g. ``('y', 'z', 'x')`` for a Z-up export whose tool moves along +x, or
            ``('x', 'y', '-z')`` for one whose tool moves along -z.
        origin_m: (3,) origin of the paper frame in paper axes [m], subtracted after the axes
            and units (the undisturbed surface above the tool's start).
        tool_start_s: Source time [s] at which the tool starts to move (pass time 0).
        dt_s: Time step of a dump's step numbers [s] (required for ``liggghts``).
        start_step: Step at which the tool starts to move (``liggghts``; the pass time is
            ``(step - start_step) * dt_s``).
    """

    format: str = 'csv'
    columns: Mapping[str, str] = field(default_factory=lambda: dict(DEFAULT_COLUMNS))
    length_unit: str = 'm'
    time_unit: str = 's'
    axes: tuple[str, str, str] = ('x', 'y', 'z')
    origin_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tool_start_s: float = 0.0
    dt_s: float | None = None
    start_step: int = 0

    def __post_init__(self) -> None:
        if self.format not in FORMATS:
            raise _bad('format', self.format, f'must be one of {list(FORMATS)}')
        if self.length_unit not in LENGTH_UNITS:
            raise _bad('length_unit', self.length_unit, f'must be one of {list(LENGTH_UNITS)}')
        if self.time_unit not in TIME_UNITS:
            raise _bad('time_unit', self.time_unit, f'must be one of {list(TIME_UNITS)}')
        names = [a.lstrip('+-').lower() for a in self.axes]
        if len(self.axes) != 3 or sorted(names) != ['x', 'y', 'z']:
            raise _bad('axes', list(self.axes), 'must name x, y and z once each, e.g. [y, z, -x]')
        unknown = set(self.columns) - set(DEFAULT_COLUMNS)
        if unknown:
            raise _bad('columns', sorted(unknown), f'keys must be among {list(DEFAULT_COLUMNS)}')
        if len(self.origin_m) != 3 or not all(math.isfinite(v) for v in self.origin_m):
            raise _bad('origin', self.origin_m, 'must be three finite numbers [m]')
        if self.format == 'liggghts' and not (self.dt_s is not None and self.dt_s > 0):
            raise _bad('dt_s', self.dt_s, 'a LIGGGHTS dump needs its time step (> 0) [s]')

    def column(self, name: str) -> str:
        """The file's (lower-case) column name for dempath's ``name``."""
        return str({**DEFAULT_COLUMNS, **self.columns}[name]).strip().lower()

    def to_paper(self, source_xyz: F64) -> F64:
        """(k, 3) source positions in the file's unit -> paper frame [m]."""
        index = {'x': 0, 'y': 1, 'z': 2}
        out = np.empty_like(source_xyz, dtype=np.float64)
        for k, axis in enumerate(self.axes):
            sign = -1.0 if axis.startswith('-') else 1.0
            out[:, k] = sign * source_xyz[:, index[axis.lstrip('+-').lower()]]
        return np.asarray(out * LENGTH_UNITS[self.length_unit] - np.asarray(self.origin_m),
                          np.float64)

    @classmethod
    def from_dict(cls, raw: Mapping[str, Any]) -> ExportMapping:
        """Build from a parsed YAML mapping (keys as in the module docstring)."""
        known = {'format', 'columns', 'length_unit', 'time_unit', 'axes', 'origin',
                 'tool_start_s', 'dt_s', 'start_step'}
        unknown = sorted(set(raw) - known)
        if unknown:
            raise _bad('keys', unknown, f'unknown; known keys are {sorted(known)}')
        try:
            return cls(format=str(raw.get('format', 'csv')),
                       columns={str(k): str(v) for k, v in dict(raw.get('columns', {})).items()},
                       length_unit=str(raw.get('length_unit', 'm')),
                       time_unit=str(raw.get('time_unit', 's')),
                       axes=tuple(str(a) for a in raw.get('axes', ('x', 'y', 'z'))),  # type: ignore[arg-type]
                       origin_m=tuple(float(v) for v in raw.get('origin', (0, 0, 0))),  # type: ignore[arg-type]
                       tool_start_s=float(raw.get('tool_start_s', 0.0)),
                       dt_s=None if raw.get('dt_s') is None else float(raw['dt_s']),
                       start_step=int(raw.get('start_step', 0)))
        except (TypeError, ValueError) as err:
            raise InputError(f'model map: {err}') from err


def load_mapping(path: str | Path) -> ExportMapping:
    """Read an :class:`ExportMapping` from a YAML file.

    Raises:
        InputError: The file is missing, not YAML, not a mapping, or a field is invalid.
    """
    import yaml

    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        raise InputError(f'{path}: cannot read the model map ({err})') from err
    if not isinstance(raw, dict):
        raise InputError(f'{path}: the model map must be a YAML mapping')
    try:
        return ExportMapping.from_dict(raw)
    except InputError as err:
        raise InputError(f'{path}: {err}') from err


def is_dump(path: Path) -> bool:
    """Whether ``path`` is a LAMMPS/LIGGGHTS text dump (first line ``ITEM: TIMESTEP``)."""
    try:
        with path.open(encoding='utf-8', errors='replace') as handle:
            return handle.readline().strip() == 'ITEM: TIMESTEP'
    except OSError:
        return False


def _tracks(path: Path, times: F64, ids: NDArray[np.int64], xyz: F64) -> list[Track]:
    """One model track per particle id, sorted by time (NaN rows dropped)."""
    info = run_info(path.stem)
    keep = np.isfinite(times) & np.isfinite(xyz).all(axis=1)
    times, ids, xyz = times[keep], ids[keep], xyz[keep]
    order = np.lexsort((times, ids))
    times, ids, xyz = times[order], ids[order], xyz[order]
    starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
    ends = np.r_[starts[1:], len(ids)]
    return [Track(f'{path.stem}/{int(ids[a])}', path.stem, int(ids[a]), 0, times[a:b],
                  xyz[a:b], '', '', *info) for a, b in zip(starts, ends, strict=True)]


def load_dump_tracks(path: str | Path, mapping: ExportMapping) -> list[Track]:
    """Model tracks of a LIGGGHTS ``dump custom`` file (every particle in it).

    Raises:
        InputError: Unreadable dump, or the id / coordinate columns are missing.
    """
    from dempath.dumpio import read_dump

    path = Path(path)
    try:
        frames = read_dump(path)
    except DumpError as err:
        raise InputError(str(err)) from err
    names = [mapping.column(c) for c in ('id', 'x', 'y', 'z')]
    cols = tuple(c.lower() for c in frames[0].columns)
    missing = [n for n in names if n not in cols]
    if missing:
        raise InputError(f'{path}: dump has no column(s) {missing}; it has {list(cols)}')
    assert mapping.dt_s is not None  # checked by ExportMapping
    parts = []
    for frame in frames:
        lower = tuple(c.lower() for c in frame.columns)
        data = frame.data[:, [lower.index(n) for n in names]]
        t = (frame.step - mapping.start_step) * mapping.dt_s
        parts.append(np.column_stack([np.full(len(data), t), data]))
    table = np.concatenate(parts) if parts else np.zeros((0, 5))
    return _tracks(path, table[:, 0], table[:, 1].astype(np.int64),
                   mapping.to_paper(table[:, 2:5]))


def load_mapped_csv(path: str | Path, mapping: ExportMapping) -> list[Track]:
    """Model tracks of a long CSV export (EDEM, Rocky, ...) read through ``mapping``.

    Raises:
        InputError: Unreadable file, a mapped column missing, non-integer ids.
    """
    path = Path(path)
    names = {c: mapping.column(c) for c in ('t', 'id', 'x', 'y', 'z')}
    raw = read_csv_columns(path, aliases=False, wanted=set(names.values()))
    missing = sorted({n for n in names.values() if n not in raw})
    if missing:
        raise InputError(f'{path}: no column(s) {missing} (from the model map); the file has '
                         f'{sorted(raw)}')
    ids = raw[names['id']]
    if not np.all(np.isfinite(ids)) or np.any(ids != np.round(ids)):
        raise InputError(f'{path}: column {names["id"]!r} must hold integer particle ids')
    times = raw[names['t']] * TIME_UNITS[mapping.time_unit] - mapping.tool_start_s
    xyz = np.column_stack([raw[names[c]] for c in ('x', 'y', 'z')])
    return _tracks(path, times, ids.astype(np.int64), mapping.to_paper(xyz))


def load_foreign(path: str | Path, mapping: ExportMapping | None) -> list[Track] | None:
    """Tracks of a foreign export, or None when ``path`` is not one (dempath's own forms).

    A dump is recognised by its first line; it needs a mapping (for its time step). A CSV is
    foreign only when a mapping of format ``csv`` is given.

    Raises:
        InputError: A dump without a mapping, or any reading error above.
    """
    path = Path(path)
    if path.is_file() and is_dump(path):
        if mapping is None or mapping.format != 'liggghts':
            raise InputError(f'{path}: a LIGGGHTS dump; give a model map (--model-map) with '
                             'format: liggghts and its time step dt_s')
        return load_dump_tracks(path, mapping)
    if mapping is not None and mapping.format == 'csv' and path.is_file():
        return load_mapped_csv(path, mapping)
    return None


__all__ = ['ExportMapping', 'is_dump', 'load_dump_tracks', 'load_foreign', 'load_mapped_csv',
           'load_mapping']
