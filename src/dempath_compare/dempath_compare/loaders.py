"""Loading trajectories from CSV files, folders of CSV files and bags.

CSV shapes (metres and seconds, header row, any column order, extra columns ignored):

- measured: ``t,marker,x,y,z`` (one row per marker and time);
- model: ``t,id,x,y,z``, optionally with a ``marker`` column naming the marker a particle is a
  candidate of;
- one trajectory per file: ``t,x,y,z``; the marker number / particle id is the last number in
  the file name (the paper's layout).

In a folder, as in the paper (sec. 2.5), files with "experiment" in the name are measured data
and the others model data. Bags hold ``dempath_msgs/MarkerPoints3D`` (measured) and
``dempath_msgs/ParticleStates`` (model) on the topics of :mod:`dempath.topics`.
"""

from __future__ import annotations

import csv
import json
import logging
import re
from collections.abc import Collection, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from dempath.errors import OutputError
from dempath.outputs import check_output_folder
from dempath_compare.errors import InputError
from dempath_compare.records import MEASURED, MODEL, Track
from dempath_compare.runinfo import run_info

if TYPE_CHECKING:
    from dempath_compare.foreign import ExportMapping

log = logging.getLogger(__name__)

EXPERIMENT_KEYWORD = 'experiment'
ALIASES = {'time': 't', 't_s': 't', 'marker_id': 'marker', 'particle_id': 'id',
           'x_m': 'x', 'y_m': 'y', 'z_m': 'z'}


def read_csv_columns(path: Path, aliases: bool = True,
                     wanted: Collection[str] | None = None) -> dict[str, NDArray[np.float64]]:
    """Columns of a CSV file by lower-case header name, as float arrays (blank -> NaN).

    Args:
        path: The CSV file.
        aliases: Map dempath's alias names (``time``, ``x_m``...) to ``t``, ``x``...; a
            mapped foreign export keeps its own names.
        wanted: Only these (lower-case) columns are parsed (others may hold text); all when None.
    """
    try:
        with path.open(newline='') as handle:
            rows = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError) as err:
        msg = f'{path}: cannot read CSV file ({err})'
        raise InputError(msg) from err
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    if not rows:
        msg = f'{path}: empty CSV file'
        raise InputError(msg)
    names = [h.strip().lower() for h in rows[0]]
    header = [ALIASES.get(h, h) for h in names] if aliases else names
    width = len(header)
    if any(len(r) != width for r in rows[1:]):
        bad = next(i for i, r in enumerate(rows[1:], 2) if len(r) != width)
        msg = f'{path}: line {bad} has a different number of fields than the header'
        raise InputError(msg)
    keep = [k for k, name in enumerate(header) if wanted is None or name in wanted]
    try:
        data = np.array([[float(r[k]) if r[k].strip() else np.nan for k in keep]
                         for r in rows[1:]], dtype=np.float64).reshape(len(rows) - 1, len(keep))
    except ValueError as err:
        msg = f'{path}: non-numeric value ({err})'
        raise InputError(msg) from err
    return {header[k]: data[:, j] for j, k in enumerate(keep)}


def load_csv(path: str | Path, kind: str, meta: dict[str, Any] | None = None,
             from_names: bool = False) -> list[Track]:
    """Tracks of one CSV file.

    Args:
        path: CSV file in one of the module's shapes.
        kind: ``MEASURED`` or ``MODEL`` (decides whether ``marker`` or ``id`` names a track).
        meta: run metadata (a ``dempath simulate`` summary.json) for the speed, run id, seed,
            scene and physics keys (:mod:`dempath_compare.runinfo`).
        from_names: what the metadata do not say from the file name (speed, seed).

    Raises:
        InputError: unreadable file, missing columns, non-integer ids.
    """
    path = Path(path)
    cols = read_csv_columns(path)
    missing = [c for c in ('t', 'x', 'y', 'z') if c not in cols]
    if missing:
        msg = f'{path}: missing column(s) {missing}; expected t,marker|id,x,y,z'
        raise InputError(msg)
    key = 'marker' if kind == MEASURED else ('id' if 'id' in cols else 'marker')
    n_rows = len(cols['t'])
    if key in cols:
        idents = _integers(path, key, cols[key])
    else:
        t = cols['t'][np.isfinite(cols['t'])]
        if len(np.unique(t)) < len(t):  # one file of one particle has each time once
            msg = (f'{path}: no {key!r} column, and its times repeat (rows of several '
                   f'{key}s?); give a {key} column: t,{key},x,y,z')
            raise InputError(msg)
        idents = np.full(n_rows, _number_in_name(path), dtype=np.int64)
    markers = _integers(path, 'marker', cols['marker']) if 'marker' in cols else None
    xyz = np.stack([cols['x'], cols['y'], cols['z']], axis=1)
    info = run_info(path.stem, meta, from_names)
    tracks = []
    for ident in dict.fromkeys(idents.tolist()):
        rows = np.flatnonzero(idents == ident)
        marker = ident if kind == MEASURED else (int(markers[rows[0]]) if markers is not None
                                                 else 0)
        label = f'{path.stem}/marker{ident}' if kind == MEASURED else f'{path.stem}/{ident}'
        tracks.append(Track(label, path.stem, int(ident), marker, cols['t'][rows], xyz[rows],
                            '', '', *info))
    return tracks


def _integers(path: Path, name: str, values: NDArray[np.float64]) -> NDArray[np.int64]:
    if not np.all(np.isfinite(values)) or np.any(values != np.round(values)):
        msg = f'{path}: column {name!r} must hold integers'
        raise InputError(msg)
    return values.astype(np.int64)


def _number_in_name(path: Path) -> int:
    numbers = re.findall(r'\d+', path.stem)
    return int(numbers[-1]) if numbers else 0


def csv_files(folder: Path, kind: str) -> list[Path]:
    """CSV files of ``kind`` in a folder: "experiment" in the name for measured, else model.

    A folder without any "experiment" file is taken as entirely measured when ``kind`` is
    measured (a folder given on purpose for the measured side).
    """
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() == '.csv' and p.is_file())
    if not files and any(p.suffix.lower() in {'.mcap', '.db3'} for p in folder.iterdir()):
        msg = (f'{folder}: a bag without metadata.yaml (a recording that was cut off?); run '
               f"'dempath bag-recover {folder}' first")
        raise InputError(msg)
    if not files:
        msg = f'{folder}: no CSV files in folder'
        raise InputError(msg)
    experiment = [p for p in files if EXPERIMENT_KEYWORD in p.name.lower()]
    if kind == MEASURED:
        return experiment or files
    chosen = [p for p in files if p not in experiment]
    if not chosen:
        msg = f'{folder}: no model CSV files (every file has {EXPERIMENT_KEYWORD!r} in its name)'
        raise InputError(msg)
    return chosen


def run_model_files(folder: Path) -> list[Path]:
    """The model tracks of a ``dempath simulate`` folder: its ``model.csv`` alone.

    ``model.csv`` tags every tracked particle with the marker it stands for or is a Cube
    candidate of, so each marker is ranked against its own candidates (the paper's N best).
    The folder's other CSV files are not model tracks: ``markers.csv`` repeats one particle per
    marker (every marker's N would be 1) and ``tool.csv`` is the tool's pose and force.

    Raises:
        InputError: the folder has a ``summary.json`` but no ``model.csv``.
    """
    model = folder / 'model.csv'
    if not model.is_file():
        msg = f'{folder}: a dempath simulate folder (summary.json) without model.csv'
        raise InputError(msg)
    return [model]


def is_bag(path: Path) -> bool:
    """A rosbag2 directory or a bare .mcap / .db3 file."""
    return (path.is_dir() and (path / 'metadata.yaml').is_file()) or \
        path.suffix.lower() in {'.mcap', '.db3'}


def load_source(path: str | Path, kind: str, mapping: ExportMapping | None = None,
                from_names: bool = False) -> list[Track]:
    """Tracks of ``kind`` from a CSV file, a folder of CSV files, a bag or (model side) a
    foreign export: a LIGGGHTS dump or a CSV read through ``mapping`` (:mod:`.foreign`).

    A model folder's ``summary.json`` (run metadata) gives its tracks' identity; ``from_names``
    fills what no metadata say from the names (``CompareConfig.identity_from_names``).

    Raises:
        InputError: missing path, empty folder, unreadable file, nothing of ``kind`` found.
    """
    from dempath_compare.foreign import load_foreign

    path = Path(path)
    if not path.exists():
        msg = f'{path}: no such file or folder'
        raise InputError(msg)
    foreign = load_foreign(path, mapping) if kind == MODEL else None
    if foreign is not None:
        tracks = foreign
    elif is_bag(path):
        from dempath_compare.bagload import load_bag

        tracks = load_bag(path, kind, from_names)
    elif path.is_dir():
        try:
            check_output_folder(path, 'summary.json')
        except OutputError as err:
            raise InputError(str(err)) from err
        meta = run_metadata(path) if kind == MODEL else None
        files = run_model_files(path) if meta is not None else csv_files(path, kind)
        tracks = [t for f in files for t in load_csv(f, kind, meta, from_names)]
    elif path.suffix.lower() == '.csv':
        tracks = load_csv(path, kind, None, from_names)
    else:
        msg = f'{path}: not a CSV file, folder of CSV files or bag'
        raise InputError(msg)
    if not tracks:
        msg = f'{path}: no {kind} trajectories found'
        raise InputError(msg)
    _check_unique(path, tracks)
    log.info('%s: %d %s trajectories', path, len(tracks), kind)
    return tracks


def run_metadata(folder: Path) -> dict[str, Any] | None:
    """The ``summary.json`` of a ``dempath simulate`` output folder, None when there is none.

    Raises:
        InputError: the file exists but is not a JSON object.
    """
    path = folder / 'summary.json'
    if not path.is_file():
        return None
    try:
        meta = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as err:
        msg = f'{path}: not readable run metadata ({err})'
        raise InputError(msg) from err
    if not isinstance(meta, dict):
        msg = f'{path}: run metadata must be a JSON object'
        raise InputError(msg)
    return meta


def _check_unique(path: Path, tracks: Iterable[Track]) -> None:
    seen: set[str] = set()
    for track in tracks:
        if track.label in seen:
            msg = f'{path}: trajectory {track.label} appears twice'
            raise InputError(msg)
        seen.add(track.label)


__all__ = ['MEASURED', 'MODEL', 'csv_files', 'is_bag', 'load_csv', 'load_source']
