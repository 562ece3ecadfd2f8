"""A bed made elsewhere as the scene's packing: a LIGGGHTS data file, a CSV or an npz.

Users bring beds poured by another engine or measured in a lab (``fill.packing`` in a scene).
Formats, in metres:

- LIGGGHTS / LAMMPS data file (any name not ending in .csv or .npz), ``atom_style granular`` or
  ``sphere``: the ``Atoms`` section's rows ``id type diameter density x y z [ix iy iz]``;
- CSV with a header naming ``x,y,z,d`` (centre and diameter; other columns are ignored);
- npz with ``positions`` (n, 3) and ``radii`` (n,) or ``diameters`` (n,).

The bed is checked before anything is run or written: overlaps beyond ``OVERLAP_TOLERANCE`` of
the smaller radius (a settled soft bed legitimately overlaps by a few per cent), spheres outside
the bin's floor and side walls, and numbers that look like millimetres (spheres wider than a
quarter of the bin that fit it only when divided by 1000). Each is one SceneError naming the file.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from dempath_sim.errors import SceneError
from dempath_sim.scene.spec import SceneSpec

F64 = NDArray[np.float64]
OVERLAP_TOLERANCE = 0.1  # largest accepted overlap / smaller radius
OUTSIDE_TOLERANCE = 0.1  # a sphere may poke this fraction of its radius into a wall


def _fail(path: Path, problem: str) -> SceneError:
    return SceneError(f'{path}: {problem}')


def _read_data_file(path: Path, lines: list[str]) -> tuple[F64, F64]:
    """Centres and diameters from a LIGGGHTS data file's Atoms section."""
    try:
        start = next(k for k, line in enumerate(lines) if line.split()[:1] == ['Atoms'])
    except StopIteration:
        raise _fail(path, 'no Atoms section (expected a LIGGGHTS data file, a .csv or an '
                          '.npz)') from None
    rows: list[list[float]] = []
    for line in lines[start + 1:]:
        text = line.split('#')[0].split()
        if not text:
            if rows:
                break
            continue
        try:
            rows.append([float(v) for v in text[:7]])
        except ValueError:
            rows.append([])
        if len(rows[-1]) < 7:
            raise _fail(path, f'Atoms row {line.strip()!r}: expected id type diameter density '
                              'x y z (atom_style granular)')
    if not rows:
        raise _fail(path, 'the Atoms section is empty')
    table = np.asarray(rows)[np.argsort(np.asarray(rows)[:, 0])]
    return table[:, 4:7], table[:, 2]


def _read_csv(path: Path, text: str) -> tuple[F64, F64]:
    rows = [row for row in csv.reader(text.splitlines()) if row]
    names = [n.strip() for n in (rows[0] if rows else [])]
    if not {'x', 'y', 'z', 'd'} <= set(names):
        raise _fail(path, f'CSV header {",".join(names)!r} must name the columns x,y,z,d '
                          '(centre and diameter in m)')
    cols = [names.index(k) for k in ('x', 'y', 'z', 'd')]
    try:
        table = np.array([[float(row[c]) for c in cols] for row in rows[1:]])
    except (IndexError, ValueError) as err:
        raise _fail(path, f'a row is not numeric x,y,z,d ({err})') from None
    if not len(table):
        raise _fail(path, 'no particles')
    return table[:, :3], table[:, 3]


def _read_npz(path: Path) -> tuple[F64, F64]:
    try:
        with np.load(path, allow_pickle=False) as data:
            pos = np.asarray(data['positions'], dtype=np.float64)
            diam = (2.0 * np.asarray(data['radii'], dtype=np.float64) if 'radii' in data
                    else np.asarray(data['diameters'], dtype=np.float64))
    except (KeyError, OSError, ValueError) as err:
        raise _fail(path, f'expected an npz with positions (n, 3) and radii or diameters (n,) '
                          f'({err})') from None
    if pos.ndim != 2 or pos.shape[1:] != (3,) or diam.shape != (len(pos),):
        raise _fail(path, f'positions {pos.shape} and radii/diameters {diam.shape} do not '
                          'match (n, 3) and (n,)')
    return pos, diam


def read_packing_file(path: Path) -> tuple[F64, F64]:
    """(centres (n, 3), radii (n,)) as the file gives them, unchecked [file units]."""
    try:
        if path.suffix.lower() == '.npz':
            pos, diam = _read_npz(path)
        else:
            text = path.read_text(encoding='utf-8', errors='replace')
            pos, diam = (_read_csv(path, text) if path.suffix.lower() == '.csv'
                         else _read_data_file(path, text.splitlines()))
    except OSError as err:
        raise _fail(path, f'cannot read packing ({err.strerror})') from None
    if not (np.isfinite(pos).all() and np.isfinite(diam).all() and (diam > 0).all()):
        raise _fail(path, 'non-finite positions or non-positive diameters')
    return pos, diam / 2.0


def outside_bin(scene: SceneSpec, pos: F64, radii: F64) -> NDArray[np.bool_]:
    """(n,) bool: spheres that cross the bin's floor or side walls by more than the tolerance."""
    half_w, length, floor = scene.bin.width_x_m / 2, scene.bin.length_z_m, -scene.bed_thickness_m
    r = radii * (1.0 - OUTSIDE_TOLERANCE)
    return ((np.abs(pos[:, 0]) + r > half_w) | (pos[:, 2] - r < 0.0)
            | (pos[:, 2] + r > length) | (pos[:, 1] - r < floor))


def worst_overlap(pos: F64, radii: F64) -> tuple[float, int, int]:
    """(largest overlap / smaller radius, i, j) over all touching pairs (0, -1, -1 if none)."""
    pairs = cKDTree(pos).query_pairs(2.0 * float(radii.max()), output_type='ndarray')
    if len(pairs) == 0:
        return 0.0, -1, -1
    i, j = pairs[:, 0], pairs[:, 1]
    gap = np.linalg.norm(pos[i] - pos[j], axis=1) - radii[i] - radii[j]
    ratio = -gap / np.minimum(radii[i], radii[j])
    k = int(np.argmax(ratio))
    return float(ratio[k]), int(i[k]), int(j[k])


def load_packing(scene: SceneSpec, path: Path) -> tuple[F64, F64]:
    """Read and check the scene's packing file: (centres (n, 3) [m], radii (n,) [m]).

    Raises:
        SceneError: Unreadable, in millimetres, outside the bin, or overlapping (one line
            naming the file).
    """
    pos, radii = read_packing_file(path)
    out = outside_bin(scene, pos, radii)
    if out.any():
        too_big = 2 * float(np.median(radii)) > 0.25 * min(scene.bin.width_x_m,
                                                           scene.bin.length_z_m)
        if too_big and not outside_bin(scene, pos / 1000.0, radii / 1000.0).any():
            raise _fail(path, f'the packing looks like millimetres (median diameter '
                              f'{2 * float(np.median(radii)):g}, and it fits the bin only when '
                              'divided by 1000); give centres and diameters in metres')
        k = int(np.flatnonzero(out)[0])
        raise _fail(path, f'{int(out.sum())} particles lie outside the bin (the first at '
                          f'{pos[k].round(4).tolist()} m, radius {radii[k]:g} m; bin X '
                          f'+-{scene.bin.width_x_m / 2:g}, Z 0..{scene.bin.length_z_m:g}, floor '
                          f'Y {-scene.bed_thickness_m:g} m)')
    ratio, i, j = worst_overlap(pos, radii)
    if ratio > OVERLAP_TOLERANCE:
        raise _fail(path, f'particles {i} and {j} (file order) overlap by {100 * ratio:.1f} % '
                          f'of the smaller radius (at most {100 * OVERLAP_TOLERANCE:.0f} % is '
                          'accepted)')
    return pos, radii


__all__ = ['OVERLAP_TOLERANCE', 'load_packing', 'outside_bin', 'read_packing_file',
           'worst_overlap']
