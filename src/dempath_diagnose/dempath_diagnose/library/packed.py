"""A built signature library packed into one small file for a known marker region (to ship).

A library folder keeps every particle near the surface of every run (any layout can be served);
a user who knows where the markers start (a lab's grid, the demo's field twin) needs only the
particles around those starts. :func:`export_library` keeps, per run, the particles whose start
lies within ``margin_m`` of the candidate cube around any given marker start (or inside a box
given by the user), plus whatever :func:`.counterparts.cube_members` would take for those starts
(a grown cube, the nearest particles), so that a diagnosis of those markers finds the very same
model counterparts in the file as in the folder.

Displacements from the start are quantised to ``QUANTUM_M`` (0.05 mm at most off, far below a
camera pair's 1.5 mm noise), differenced over time and stored as int16, which deflate packs
well (a particle at rest is a run of zeros); starts, tool pose and force stay float32. NaN
(a particle that left the domain) is a packed bit mask. The design (candidates, runs) and the
region travel in the file; :func:`load_packed` gives records that :class:`.store.Library`
diagnoses from exactly as from the folder.
"""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.errors import LibraryError
from dempath_diagnose.library.counterparts import cube_members
from dempath_diagnose.records import F64, PassRecord

FORMAT = 'dempath-library-packed-1'
QUANTUM_M = 1e-4  # displacement quantum [m]: rounding error at most half of it
DEFAULT_MARGIN_M = 0.01  # kept beyond each marker's cube: measured starts may lie this far off


def select_particles(start: F64, cube: tuple[float, float, float], starts: F64 | None = None,
                     margin_m: float = DEFAULT_MARGIN_M, box: F64 | None = None,
                     ) -> NDArray[np.intp]:
    """Indices of the particles of a run to keep (sorted).

    Args:
        start: (n, 3) start positions of the run's particles [m].
        cube: Candidate cube size (X, Y, Z) [m].
        starts: (m, 3) marker starts [m]; the cube around each, grown by ``margin_m``, is kept.
        margin_m: Margin beyond each cube [m].
        box: (2, 3) lower and upper corner of a region to keep instead [m].
    """
    keep = np.zeros(len(start), bool)
    finite = np.isfinite(start).all(1)
    if box is not None:
        keep |= finite & np.all((start >= box[0]) & (start <= box[1]), axis=1)
    if starts is not None and len(starts):
        half = np.asarray(cube) / 2.0 + margin_m
        for p in starts:
            keep |= finite & np.all(np.abs(start - p) <= half, axis=1)
        for idx in cube_members(start, starts, cube):
            keep[idx] = True
    return np.flatnonzero(keep)


def _pack_record(rec: PassRecord, keep: NDArray[np.intp], k: int) -> dict[str, NDArray[Any]]:
    pos = rec.positions[:, keep].astype(np.float64)
    start = rec.positions[0, keep]
    finite = np.asarray(np.isfinite(pos).all(2))
    disp = np.where(finite[..., None], pos - start.astype(np.float64)[None], 0.0)
    q = np.rint(disp / QUANTUM_M).astype(np.int64)
    step = np.diff(q, axis=0)
    if step.size and np.abs(step).max() > np.iinfo(np.int16).max:
        raise LibraryError(f'run {k}: a particle moves over 3.2 m in one frame; cannot pack it')
    return {f'r{k}_times': rec.times, f'r{k}_ids': rec.ids[keep],
            f'r{k}_start': start.astype(np.float32), f'r{k}_steps': step.astype(np.int16),
            f'r{k}_finite': np.packbits(finite, axis=None),
            f'r{k}_tool_position': rec.tool_position.astype(np.float32),
            f'r{k}_force_times': rec.force_times,
            f'r{k}_tool_force': rec.tool_force.astype(np.float32),
            f'r{k}_meta': np.array(json.dumps(rec.meta))}


def _unpack_record(data: Any, k: int) -> PassRecord:
    times = np.asarray(data[f'r{k}_times'], np.float64)
    start = np.asarray(data[f'r{k}_start'], np.float32)
    steps = np.asarray(data[f'r{k}_steps'], np.int64)
    n = len(start)
    q = np.concatenate([np.zeros((1, n, 3), np.int64), np.cumsum(steps, axis=0)])
    finite = np.unpackbits(data[f'r{k}_finite'], count=len(times) * n).astype(bool)
    pos = (start.astype(np.float64)[None] + q * QUANTUM_M).astype(np.float32)
    pos[~finite.reshape(len(times), n)] = np.nan
    return PassRecord(times, np.asarray(data[f'r{k}_ids'], np.int64), pos,
                      np.asarray(data[f'r{k}_tool_position'], np.float64),
                      np.asarray(data[f'r{k}_force_times'], np.float64),
                      np.asarray(data[f'r{k}_tool_force'], np.float64),
                      json.loads(str(data[f'r{k}_meta'])))


def export_library(library: Any, path: Path, cube: tuple[float, float, float],
                   starts: F64 | None = None, margin_m: float = DEFAULT_MARGIN_M,
                   box: F64 | None = None) -> dict[str, Any]:
    """Pack ``library`` (a :class:`.store.Library`) for a marker region into ``path``.

    Args:
        library: The built library.
        path: The file to write (.npz; written atomically).
        cube: Candidate cube size (X, Y, Z) [m] of the scene.
        starts: (m, 3) marker starts in the scene frame [m] (the region around them is kept).
        margin_m: Margin beyond each marker's cube [m].
        box: (2, 3) corners of a region to keep [m] (with or instead of ``starts``).

    Returns:
        A summary: bytes written, runs, particles kept per run (min, max).

    Raises:
        LibraryError: Neither ``starts`` nor ``box`` given, or the file cannot be written.
    """
    if starts is None and box is None:
        raise LibraryError(f'{path}: give the marker starts or a box to pack the library for')
    arrays: dict[str, NDArray[Any]] = {}
    kept = []
    for k, run in enumerate(library.runs):
        rec = library.records[run.filename]
        keep = select_particles(rec.start, cube, starts, margin_m, box)
        kept.append(len(keep))
        arrays.update(_pack_record(rec, keep, k))
    region = {'starts': None if starts is None else np.asarray(starts).tolist(),
              'margin_m': margin_m, 'box': None if box is None else np.asarray(box).tolist(),
              'cube_m': list(cube)}
    design = {'format': FORMAT, 'source': str(library.folder), 'region': region,
              **getattr(library, 'identity', {}),
              'candidates': [asdict(c) for c in library.candidates],
              'runs': [asdict(r) for r in library.runs]}
    arrays['design'] = np.array(json.dumps(design))
    path = Path(path)
    tmp = path.with_name(path.name + '.tmp.npz')
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(tmp, **arrays)  # type: ignore[arg-type]  # numpy's stub: kwds
        os.replace(tmp, path)
    except OSError as err:
        raise LibraryError(f'{path}: cannot write the packed library ({err})') from err
    return {'path': str(path), 'bytes': path.stat().st_size, 'runs': len(library.runs),
            'particles_min': min(kept), 'particles_max': max(kept)}


def load_packed(path: Path) -> tuple[dict[str, Any], list[PassRecord]]:
    """The design and the records (in design order) of a packed library file.

    Raises:
        LibraryError: Unreadable, or not a packed library.
    """
    try:
        with np.load(path, allow_pickle=False) as data:
            design = json.loads(str(data['design']))
            if not isinstance(design, dict) or design.get('format') != FORMAT:
                found = design.get('format') if isinstance(design, dict) else None
                msg = (f'{path}: not a packed dempath library of this version (format {found!r},'
                       f' expected {FORMAT!r}); pack it again with this dempath')
                raise LibraryError(msg)
            records = [_unpack_record(data, k) for k in range(len(design['runs']))]
    except KeyError as err:  # an array or design entry of another layout
        msg = (f'{path}: a packed library of another layout (no {err}); pack it again with this '
               'dempath')
        raise LibraryError(msg) from None
    except (OSError, EOFError, zipfile.BadZipFile, ValueError, TypeError) as err:
        what = 'empty' if path.is_file() and path.stat().st_size == 0 else 'truncated or damaged'
        msg = f'{path}: unreadable packed library, {what} ({type(err).__name__}: {err})'
        raise LibraryError(msg) from None
    return design, records


def outside_region(region: dict[str, Any], starts: F64, markers: Sequence[int]) -> list[str]:
    """Markers whose start lies outside the packed region (their counterparts are not there)."""
    out = []
    box = np.asarray(region['box']) if region.get('box') is not None else None
    known = np.asarray(region['starts']) if region.get('starts') is not None else None
    margin = float(region.get('margin_m', 0.0))
    for m, p in zip(markers, starts, strict=True):
        in_box = box is not None and bool(np.all((p >= box[0]) & (p <= box[1])))
        near = known is not None and bool(
            np.any(np.all(np.abs(known - p) <= margin + 1e-9, axis=1)))
        if not (in_box or near):
            out.append(f'marker {m} at ({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}) m')
    return out
