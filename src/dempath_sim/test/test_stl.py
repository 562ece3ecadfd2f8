"""STL reader: ASCII and binary round trips, and one clear error naming the file for bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.engine.stl import read_stl, write_stl_ascii
from dempath_sim.errors import GeometryError

TRIS = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                 [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]])


def _write_binary(path: Path, tris: np.ndarray, declared: int | None = None) -> None:
    rec = np.dtype([('normal', '<f4', 3), ('v', '<f4', (3, 3)), ('attr', '<u2')])
    body = np.zeros(len(tris), dtype=rec)
    body['v'] = tris
    count = np.array([len(tris) if declared is None else declared], dtype='<u4')
    path.write_bytes(b'binary stl'.ljust(80, b' ') + count.tobytes() + body.tobytes())


def test_ascii_round_trip(tmp_path: Path) -> None:
    """Triangles written as ASCII STL read back identically."""
    path = tmp_path / 'plate.stl'
    write_stl_ascii(path, TRIS)
    np.testing.assert_allclose(read_stl(path), TRIS)


def test_binary_read(tmp_path: Path) -> None:
    """A binary STL (even one whose header starts with 'solid') is read as binary."""
    path = tmp_path / 'plate.stl'
    _write_binary(path, TRIS)
    np.testing.assert_allclose(read_stl(path), TRIS)
    data = path.read_bytes()
    path.write_bytes(b'solid but binary'.ljust(80) + data[80:])
    np.testing.assert_allclose(read_stl(path), TRIS)


def test_mesh_from_stl_scales_and_offsets(tmp_path: Path) -> None:
    """TriangleMesh.from_stl applies scale then offset (mm file -> m)."""
    path = tmp_path / 'plate_mm.stl'
    write_stl_ascii(path, TRIS * 1000.0)
    mesh = TriangleMesh.from_stl(path, material=1, scale=1e-3, offset=(0.0, 0.5, 0.0))
    lo, hi = mesh.bounds
    np.testing.assert_allclose(lo, [0.0, 0.5, 0.0])
    np.testing.assert_allclose(hi, [1.0, 1.5, 0.0])
    assert mesh.material == 1


def test_truncated_binary_names_file(tmp_path: Path) -> None:
    """A binary STL shorter than its triangle count says so and names the file."""
    path = tmp_path / 'cut.stl'
    _write_binary(path, TRIS, declared=5)
    with pytest.raises(GeometryError, match=r'cut\.stl.*declares 5 triangles'):
        read_stl(path)


def test_malformed_ascii_names_file_and_line(tmp_path: Path) -> None:
    """A vertex line with a non-number gives the file and line number."""
    path = tmp_path / 'bad.stl'
    write_stl_ascii(path, TRIS)
    text = path.read_text().replace('vertex 1 0 0', 'vertex 1 zero 0', 1)
    path.write_text(text)
    with pytest.raises(GeometryError, match=r'bad\.stl.*line 5: malformed vertex'):
        read_stl(path)


def test_ascii_with_missing_vertex_is_rejected(tmp_path: Path) -> None:
    """A facet with two vertices is reported with the facet and vertex counts."""
    path = tmp_path / 'short.stl'
    write_stl_ascii(path, TRIS)
    lines = path.read_text().splitlines()
    path.write_text('\n'.join(lines[:4] + lines[5:]))
    with pytest.raises(GeometryError, match=r'short\.stl.*2 facets but 5 vertices'):
        read_stl(path)


@pytest.mark.parametrize('content', [b'', b'   \n'])
def test_empty_file_names_file(tmp_path: Path, content: bytes) -> None:
    """An empty STL file is one clear error naming the file."""
    path = tmp_path / 'empty.stl'
    path.write_bytes(content)
    with pytest.raises(GeometryError, match=r'empty\.stl.*empty'):
        read_stl(path)


def test_missing_file_names_file(tmp_path: Path) -> None:
    """A missing STL file is reported with its path."""
    with pytest.raises(GeometryError, match=r'nope\.stl.*cannot read'):
        read_stl(tmp_path / 'nope.stl')
