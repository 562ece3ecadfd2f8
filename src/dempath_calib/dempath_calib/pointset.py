"""The calibration point set: pixel pairs of both cameras with their 3D world position.

Every board corner seen by both cameras in one frame gives one sample
``(xs, ys, xf, yf) -> (X, Y, Z)`` (the paper had 94,939). File formats:

- ``.npz``: arrays ``pixels`` (n, 4) float64 px, ``xyz`` (n, 3) float64 m, ``view`` (n,) int64,
  ``corner_id`` (n,) int64.
- ``.csv``: header ``xs,ys,xf,yf,X,Y,Z,view,corner_id``, one sample per line, pixels in px,
  X Y Z in metres (world frame: X lateral, Y up, Z travel).
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dempath_calib.errors import CalibrationFileError

CSV_HEADER = 'xs,ys,xf,yf,X,Y,Z,view,corner_id'


class PointSet(NamedTuple):
    """Calibration samples.

    Attributes:
        pixels: (n, 4) px, (xs, ys) in the side camera and (xf, yf) in the front camera.
        xyz: (n, 3) m, the corner's position in the world frame.
        view: (n,) index of the frame (board pose) the sample comes from.
        corner_id: (n,) ChArUco corner id on the board.
    """

    pixels: NDArray[np.float64]
    xyz: NDArray[np.float64]
    view: NDArray[np.int64]
    corner_id: NDArray[np.int64]

    def __len__(self) -> int:  # type: ignore[override]
        return int(self.pixels.shape[0])

    def subset(self, mask: NDArray[np.bool_] | NDArray[np.int64]) -> PointSet:
        """Rows selected by a boolean mask or index array."""
        return PointSet(self.pixels[mask], self.xyz[mask], self.view[mask], self.corner_id[mask])


def make_point_set(pixels: ArrayLike, xyz: ArrayLike, view: ArrayLike,
                   corner_id: ArrayLike) -> PointSet:
    """Build a PointSet with checked shapes and dtypes.

    Raises:
        ValueError: shapes do not agree.
    """
    pix = np.asarray(pixels, dtype=np.float64).reshape(-1, 4)
    pts = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    v = np.asarray(view, dtype=np.int64).ravel()
    c = np.asarray(corner_id, dtype=np.int64).ravel()
    if not len(pix) == len(pts) == len(v) == len(c):
        msg = f'point set: lengths differ (pixels {len(pix)}, xyz {len(pts)}, view {len(v)}, ' \
              f'corner_id {len(c)})'
        raise ValueError(msg)
    return PointSet(pix, pts, v, c)


def concat_point_sets(sets: list[PointSet]) -> PointSet:
    """Concatenate point sets (views keep their numbers)."""
    if not sets:
        return make_point_set(np.zeros((0, 4)), np.zeros((0, 3)), np.zeros(0), np.zeros(0))
    return make_point_set(*(np.concatenate([getattr(s, f) for s in sets])
                            for f in PointSet._fields))


def save_point_set(path: str | Path, ps: PointSet) -> Path:
    """Write ``ps`` to ``.npz`` or ``.csv`` (chosen by the suffix); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == '.csv':
        table = np.column_stack([ps.pixels, ps.xyz, ps.view, ps.corner_id])
        fmt = ['%.6f'] * 4 + ['%.9f'] * 3 + ['%d', '%d']
        np.savetxt(path, table, fmt=fmt, delimiter=',', header=CSV_HEADER, comments='')
    elif path.suffix == '.npz':
        np.savez_compressed(path, pixels=ps.pixels, xyz=ps.xyz, view=ps.view,
                            corner_id=ps.corner_id)
    else:
        msg = f'{str(path)!r}: point set file must end in .npz or .csv'
        raise CalibrationFileError(msg)
    return path


def load_point_set(path: str | Path) -> PointSet:
    """Read a point set written by ``save_point_set``.

    Raises:
        CalibrationFileError: missing, unreadable or malformed file.
    """
    path = Path(path)
    if not path.is_file():
        msg = f'{str(path)!r}: point set file not found'
        raise CalibrationFileError(msg)
    try:
        if path.suffix == '.csv':
            return _load_csv(path)
        with np.load(path) as data:
            return make_point_set(data['pixels'], data['xyz'], data['view'], data['corner_id'])
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as err:
        msg = f'{str(path)!r}: not a dempath point set ({type(err).__name__}: {err})'
        raise CalibrationFileError(msg) from err


def _load_csv(path: Path) -> PointSet:
    header = path.open().readline().strip()
    if header != CSV_HEADER:
        msg = f'header {header!r} is not {CSV_HEADER!r}'
        raise ValueError(msg)
    table = np.loadtxt(path, delimiter=',', skiprows=1, ndmin=2)
    if table.size == 0:
        table = np.zeros((0, 9))
    return make_point_set(table[:, :4], table[:, 4:7], table[:, 7].astype(np.int64),
                          table[:, 8].astype(np.int64))
