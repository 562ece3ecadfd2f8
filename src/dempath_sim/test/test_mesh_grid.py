"""The tool's triangle grid: compiled binning equals the obvious version; big meshes are fast,
report progress, stop on Ctrl-C and are warned about."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from numpy.typing import NDArray

from dempath_sim.engine import mesh as mesh_module
from dempath_sim.engine.mesh import TriangleMesh, build_triangle_grid, closest_point_triangle_numpy


def reference_pairs(tris: NDArray[np.float64], margin: float, lo: NDArray[np.float64],
                    cell: float, dims: NDArray[np.int64]) -> set[tuple[int, int]]:
    """(cell id, triangle) pairs found by looping over every cell of every triangle's box."""
    reach = margin + 0.5 * math.sqrt(3.0) * cell
    pairs = set()
    for t, tri in enumerate(tris):
        c_lo = np.clip(np.floor((tri.min(axis=0) - margin - lo) / cell).astype(int), 0, dims - 1)
        c_hi = np.clip(np.floor((tri.max(axis=0) + margin - lo) / cell).astype(int), 0, dims - 1)
        for gx in range(c_lo[0], c_hi[0] + 1):
            for gy in range(c_lo[1], c_hi[1] + 1):
                for gz in range(c_lo[2], c_hi[2] + 1):
                    centre = lo + (np.array([gx, gy, gz]) + 0.5) * cell
                    q = closest_point_triangle_numpy(centre, tri)
                    if np.linalg.norm(centre - q) <= reach * (1 + 1e-12):
                        pairs.add((int((gx * dims[1] + gy) * dims[2] + gz), t))
    return pairs


def grid_pairs(grid: mesh_module.TriangleGrid) -> set[tuple[int, int]]:
    """(cell id, triangle) pairs stored in the grid's CSR arrays."""
    counts = np.diff(grid.cell_start)
    cells = np.repeat(np.arange(len(counts)), counts)
    return set(zip(cells.tolist(), grid.cell_tris.tolist(), strict=True))


def random_mesh(n: int, seed: int) -> TriangleMesh:
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-0.05, 0.05, (n, 1, 3))
    return TriangleMesh(centres + rng.normal(0.0, 0.01, (n, 3, 3)), name='random')


def test_grid_matches_the_obvious_binning() -> None:
    """Every (cell, triangle) pair of the compiled grid is the slow loop's, and only those."""
    mesh = random_mesh(40, 3)
    grid = build_triangle_grid(mesh, 0.004)
    assert grid_pairs(grid) == reference_pairs(mesh.triangles, 0.004, grid.lo, grid.cell,
                                               grid.dims)
    assert grid.cell_start[-1] == len(grid.cell_tris)


def test_grid_chunks_agree_and_report_progress(monkeypatch: pytest.MonkeyPatch) -> None:
    """Binning in chunks gives the same grid, with one progress call per chunk."""
    mesh = random_mesh(250, 5)
    whole = build_triangle_grid(mesh, 0.003)
    monkeypatch.setattr(mesh_module, 'GRID_CHUNK', 60)
    calls: list[tuple[int, int]] = []
    chunked = build_triangle_grid(mesh, 0.003, progress=lambda d, n: calls.append((d, n)))
    assert calls == [(60, 250), (120, 250), (180, 250), (240, 250), (250, 250)]
    assert np.array_equal(whole.cell_start, chunked.cell_start)
    assert np.array_equal(whole.cell_tris, chunked.cell_tris)


def test_grid_build_stops_on_ctrl_c(monkeypatch: pytest.MonkeyPatch) -> None:
    """A KeyboardInterrupt raised between chunks (Ctrl-C) ends the build."""
    monkeypatch.setattr(mesh_module, 'GRID_CHUNK', 10)
    done: list[int] = []

    def interrupt(d: int, n: int) -> None:
        done.append(d)
        if d >= 30:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        build_triangle_grid(random_mesh(100, 1), 0.003, progress=interrupt)
    assert done == [10, 20, 30]


def test_big_mesh_is_warned_about(monkeypatch: pytest.MonkeyPatch,
                                  caplog: pytest.LogCaptureFixture) -> None:
    """A mesh above SLOW_TRIANGLES gets one warning naming it and its triangle count."""
    monkeypatch.setattr(mesh_module, 'SLOW_TRIANGLES', 50)
    with caplog.at_level(logging.WARNING, logger='dempath_sim.engine.mesh'):
        build_triangle_grid(random_mesh(80, 2), 0.003)
    assert any('random' in r.getMessage() and '80 triangles' in r.getMessage()
               for r in caplog.records)


def test_million_triangle_grid_builds() -> None:
    """A 1.2 M-triangle tool (a finely tessellated plate) is binned in one call (the per-triangle
    Python loop took minutes and gigabytes for such meshes)."""
    n = 775  # 2 * 775**2 = 1.2 M triangles over a 0.3 m plate
    u = np.linspace(0.0, 0.3, n + 1)
    x, z = np.meshgrid(u, u, indexing='ij')
    v = np.stack([x, np.zeros_like(x), z], axis=-1)
    a, b, c, d = v[:-1, :-1], v[1:, :-1], v[1:, 1:], v[:-1, 1:]
    tris = np.concatenate([np.stack([a, b, c], -2).reshape(-1, 3, 3),
                           np.stack([a, c, d], -2).reshape(-1, 3, 3)])
    grid = build_triangle_grid(TriangleMesh(tris, name='plate'), 0.002)
    assert len(np.unique(grid.cell_tris)) == len(tris)
