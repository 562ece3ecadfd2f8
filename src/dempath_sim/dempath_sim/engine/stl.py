"""STL reader (ASCII and binary) with one clear error naming the file.

Binary STL: 80-byte header, uint32 triangle count, then per triangle 12 float32 (normal, three
vertices) and a uint16 attribute; the file size must be 84 + 50 n. ASCII STL: `solid` ...
`facet normal` / `outer loop` / three `vertex x y z` / `endloop` / `endfacet` ... `endsolid`.
Normals in the file are ignored (recomputed from the vertex order by the mesh).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath_sim.errors import GeometryError


def read_stl(path: str | Path) -> NDArray[np.float64]:
    """Read an STL file.

    Args:
        path: File path.

    Returns:
        (n_triangles, 3, 3) vertex coordinates in the file's units.

    Raises:
        GeometryError: Missing, empty, truncated or malformed file, or no triangles.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as err:
        msg = f'{str(path)!r}: cannot read STL file ({err.strerror})'
        raise GeometryError(msg) from err
    if not data.strip():
        msg = f'{str(path)!r}: STL file is empty'
        raise GeometryError(msg)
    is_ascii = data.lstrip()[:5].lower() == b'solid' and b'facet' in data[:4096]
    if is_ascii or (data.lstrip()[:5].lower() == b'solid' and len(data) < 84):
        tris = _parse_ascii(path, data)
    else:
        tris = _parse_binary(path, data)
    if len(tris) == 0:
        msg = f'{str(path)!r}: STL file has no triangles'
        raise GeometryError(msg)
    if not np.isfinite(tris).all():
        msg = f'{str(path)!r}: STL file has non-finite vertex coordinates'
        raise GeometryError(msg)
    return tris


def _parse_binary(path: Path, data: bytes) -> NDArray[np.float64]:
    if len(data) < 84:
        msg = f'{str(path)!r}: binary STL truncated ({len(data)} bytes, header needs 84)'
        raise GeometryError(msg)
    count = int(np.frombuffer(data, dtype='<u4', count=1, offset=80)[0])
    expected = 84 + 50 * count
    if len(data) != expected:
        msg = (f'{str(path)!r}: binary STL declares {count} triangles ({expected} bytes) '
               f'but has {len(data)} bytes (truncated or not an STL)')
        raise GeometryError(msg)
    rec = np.dtype([('normal', '<f4', 3), ('v', '<f4', (3, 3)), ('attr', '<u2')])
    return np.frombuffer(data, dtype=rec, count=count, offset=84)['v'].astype(np.float64)


def _parse_ascii(path: Path, data: bytes) -> NDArray[np.float64]:
    try:
        text = data.decode('ascii')
    except UnicodeDecodeError as err:
        msg = f'{str(path)!r}: ASCII STL contains non-ASCII bytes at offset {err.start}'
        raise GeometryError(msg) from err
    verts: list[list[float]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        words = line.split()
        if not words or words[0] != 'vertex':
            continue
        try:
            if len(words) != 4:
                raise ValueError(line)
            verts.append([float(w) for w in words[1:]])
        except ValueError as err:
            msg = f'{str(path)!r}: line {number}: malformed vertex {line.strip()!r}'
            raise GeometryError(msg) from err
    n_facets = sum(1 for line in text.splitlines() if line.split()[:1] == ['facet'])
    if len(verts) != 3 * n_facets or len(verts) % 3:
        msg = (f'{str(path)!r}: ASCII STL has {n_facets} facets but {len(verts)} vertices '
               f'(expected 3 per facet)')
        raise GeometryError(msg)
    if 'endsolid' not in text:
        msg = f'{str(path)!r}: ASCII STL has no endsolid (truncated)'
        raise GeometryError(msg)
    return np.asarray(verts, dtype=np.float64).reshape(-1, 3, 3)


def write_stl_ascii(path: str | Path, triangles: NDArray[np.float64], name: str = 'mesh') -> None:
    """Write (n, 3, 3) triangles as an ASCII STL (normals from the vertex order)."""
    lines = [f'solid {name}']
    for tri in np.asarray(triangles, dtype=np.float64):
        nrm = np.cross(tri[1] - tri[0], tri[2] - tri[0])
        length = np.linalg.norm(nrm)
        nrm = nrm / length if length > 0 else nrm
        lines.append(f'  facet normal {nrm[0]:.9g} {nrm[1]:.9g} {nrm[2]:.9g}')
        lines.append('    outer loop')
        lines.extend(f'      vertex {v[0]:.9g} {v[1]:.9g} {v[2]:.9g}' for v in tri)
        lines.append('    endloop')
        lines.append('  endfacet')
    lines.append(f'endsolid {name}')
    Path(path).write_text('\n'.join(lines) + '\n', encoding='ascii')
