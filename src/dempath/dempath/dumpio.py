"""Read LIGGGHTS text dumps (``dump custom``) and ``fix print`` files into arrays.

A file format, like the bags of :mod:`dempath.bagio`: it lives on the ground so that both the
simulator (which drives LIGGGHTS) and the comparison (which reads a user's LIGGGHTS model) use
one parser without the comparison importing the simulator.

A dump is a sequence of frames::

    ITEM: TIMESTEP / <step> / ITEM: NUMBER OF ATOMS / <n> / ITEM: BOX BOUNDS ... (3 lines) /
    ITEM: ATOMS id x y z ... / <n rows>

:func:`read_dump` returns every frame's step and a table keyed by the column names;
:func:`frames_by_id` lays the frames out as fixed-shape (nt, n, k) arrays for a given id list,
NaN where a particle is absent (lost from the box), as the dempath Recorder does.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath.errors import DumpError

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class DumpFrame:
    """One frame of a custom dump.

    Attributes:
        step: Time step number.
        columns: Column names of the ATOMS section.
        data: (n, len(columns)) values.
    """

    step: int
    columns: tuple[str, ...]
    data: F64

    def column(self, name: str) -> F64:
        """(n,) values of one column."""
        return self.data[:, self.columns.index(name)]


def _fail(path: Path, what: str) -> DumpError:
    return DumpError(f'{path}: {what}')


def read_dump(path: str | Path) -> list[DumpFrame]:
    """Every frame of a LIGGGHTS ``dump custom`` text file.

    Raises:
        DumpError: The file is missing, empty or truncated, or a frame is malformed.
    """
    path = Path(path)
    try:
        lines = path.read_text().splitlines()
    except OSError as err:
        raise _fail(path, f'cannot read dump ({err.strerror})') from err
    frames, k = [], 0
    while k < len(lines):
        if lines[k].strip() != 'ITEM: TIMESTEP':
            raise _fail(path, f'line {k + 1}: expected "ITEM: TIMESTEP", got {lines[k]!r}')
        try:
            step, n = int(lines[k + 1]), int(lines[k + 3])
            head = lines[k + 8].split()
        except (IndexError, ValueError) as err:
            raise _fail(path, f'line {k + 1}: truncated or malformed frame header') from err
        if head[:2] != ['ITEM:', 'ATOMS']:
            raise _fail(path, f'line {k + 9}: expected "ITEM: ATOMS ...", got {lines[k + 8]!r}')
        rows = lines[k + 9:k + 9 + n]
        if len(rows) != n:
            raise _fail(path, f'frame at step {step}: {len(rows)} of {n} atom rows (truncated)')
        cols = tuple(head[2:])
        data = (np.array([r.split() for r in rows], dtype=np.float64).reshape(n, len(cols))
                if n else np.zeros((0, len(cols))))
        frames.append(DumpFrame(step, cols, data))
        k += 9 + n
    if not frames:
        raise _fail(path, 'empty dump (no frame)')
    return frames


def frames_by_id(frames: list[DumpFrame], ids: NDArray[np.int64],
                 columns: tuple[str, ...]) -> F64:
    """(nt, len(ids), len(columns)) values for the wanted ids; NaN where an id is absent."""
    out = np.full((len(frames), len(ids), len(columns)), np.nan)
    wanted = np.asarray(ids, dtype=np.int64)
    for f, frame in enumerate(frames):
        have = frame.column('id').astype(np.int64)
        order = np.argsort(have)
        pos = np.clip(np.searchsorted(have, wanted, sorter=order), 0, max(len(have) - 1, 0))
        if not len(have):
            continue
        idx = order[pos]
        found = have[idx] == wanted
        cols = [frame.columns.index(c) for c in columns]
        out[f, found] = frame.data[np.ix_(idx[found], cols)]
    return out


def read_print(path: str | Path, n_columns: int) -> F64:
    """(nt, n_columns) numbers of a ``fix print`` file (comment lines skipped).

    Raises:
        DumpError: Missing file or a row with another number of columns.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as err:
        raise _fail(path, f'cannot read print file ({err.strerror})') from err
    rows = [line.split() for line in text.splitlines() if line and not line.startswith('#')]
    bad = [k for k, r in enumerate(rows) if len(r) != n_columns]
    if bad:
        raise _fail(path, f'row {bad[0] + 1} has {len(rows[bad[0]])} columns, '
                          f'expected {n_columns}')
    return np.array(rows, dtype=np.float64).reshape(len(rows), n_columns)
