"""Compiled kernels run the current laws: the numba cache is dropped when kernel sources change,
and the engine's plane, mesh and pair kernels apply ``coulomb_limit`` as the law does."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from dempath_sim.engine import Engine, ToolPose
from dempath_sim.engine.kernel_cache import (
    KERNEL_STAMP,
    kernel_source_digest,
    refresh_kernel_cache,
)
from dempath_sim.engine.laws.dispatch import (
    TAB_CN,
    TAB_CT,
    TAB_KN,
    TAB_KT,
    TAB_MUS,
    build_pair_table,
)
from dempath_sim.engine.laws.hertz_mindlin import hertz_mindlin
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState

TILT = math.radians(25.0)
NORMAL = np.array([0.0, math.cos(TILT), math.sin(TILT)])  # of the inclined steel face
R = 0.006  # sphere radius [m]
DT = 2e-6  # [s]


def test_cache_dropped_when_kernel_sources_change(tmp_path: Path) -> None:
    """Cache files of the package's modules go when a kernel module changes, others stay."""
    pkg, cache = tmp_path / 'pkg', tmp_path / 'cache'
    pkg.mkdir()
    cache.mkdir()
    (pkg / 'law.py').write_text('from numba import njit\n')
    (pkg / 'cli.py').write_text('x = 1\n')
    names = ('law.f-3.py311.nbi', 'law.f-3.py311.1.nbc', 'other.g-1.py311.nbi', 'notes.txt')
    for name in names:
        (cache / name).write_text('x')
    digest = kernel_source_digest(pkg)
    assert refresh_kernel_cache(cache, pkg, digest) == 2
    assert sorted(p.name for p in cache.iterdir()) == sorted(
        [KERNEL_STAMP, 'other.g-1.py311.nbi', 'notes.txt'])
    (cache / names[0]).write_text('x')
    (pkg / 'cli.py').write_text('x = 2\n')  # no kernel in it: same digest, cache kept
    assert kernel_source_digest(pkg) == digest
    assert refresh_kernel_cache(cache, pkg, kernel_source_digest(pkg)) == 0
    (pkg / 'law.py').write_text('from numba import njit  # changed law\n')
    assert refresh_kernel_cache(cache, pkg, kernel_source_digest(pkg)) == 1
    assert not (cache / names[0]).exists()


def test_digest_covers_kernel_modules_in_subpackages(tmp_path: Path) -> None:
    """A law in a sub-package (engine/laws/) is part of the digest, moved or changed."""
    pkg = tmp_path / 'engine'
    (pkg / 'laws').mkdir(parents=True)
    (pkg / 'boundary.py').write_text('from numba import njit\n')
    (pkg / 'laws' / 'hertz.py').write_text('from numba import njit\n')
    digest = kernel_source_digest(pkg)
    (pkg / 'laws' / 'hertz.py').write_text('from numba import njit  # changed law\n')
    changed = kernel_source_digest(pkg)
    assert changed != digest
    (pkg / 'laws' / 'hertz.py').rename(pkg / 'hertz.py')  # same text, moved
    assert kernel_source_digest(pkg) not in (digest, changed)


def test_every_kernel_directory_has_its_cache_refreshed() -> None:
    """Each engine directory holding kernel modules has a kernel whose cache is refreshed."""
    import dempath_sim.engine as engine_pkg
    from dempath_sim.engine.kernel_cache import _KERNELS_BY_DIRECTORY

    root = Path(engine_pkg.__file__).parent
    kernel_dirs = {p.parent for p in root.rglob('*.py') if 'njit' in p.read_text()}
    refreshed = {Path(k.py_func.__code__.co_filename).parent for k in _KERNELS_BY_DIRECTORY}
    assert kernel_dirs == refreshed == {root, root / 'laws'}


def _params(limit: str) -> SimParams:
    """Sand (Table 6 modulus, bulk density) on steel, mu_s = mu_d = 0.4, no gravity."""
    sand = Material('sand', 1734.0, 1.7e6, 0.25)
    steel = Material('steel', 7800.0, 2.1e11, 0.3)
    inter = Interaction(0.3, 0.4, 0.4, 0.0)
    return SimParams(materials=(sand, steel), interactions={(0, 0): inter, (0, 1): inter},
                     dt=DT, coulomb_limit=limit, gravity=(0.0, 0.0, 0.0))


def _expected(params: SimParams, delta: float, r_eff: float, m_eff: float,
              v_rel: np.ndarray, n: np.ndarray, a: int, b: int) -> tuple[float, np.ndarray]:
    """(F_n, F_t) on body i after one step of a fresh contact, from the law itself."""
    tab = build_pair_table(params)[a, b]
    hist = np.zeros((1, 3))
    law = getattr(hertz_mindlin, 'py_func', hertz_mindlin)
    f_n, fx, fy, fz, _ = law(delta, r_eff, m_eff, tab[TAB_KN], tab[TAB_KT], tab[TAB_CN],
                             tab[TAB_CT], tab[TAB_MUS], tab[TAB_MUS], *n, *v_rel, hist, 0, DT,
                             1.0 if params.coulomb_limit == 'spring' else 0.0)
    return f_n, np.array([fx, fy, fz])


@pytest.mark.parametrize('limit', ['spring', 'total'])
def test_mesh_kernel_applies_the_coulomb_limit(limit: str) -> None:
    """A sphere struck by a face moving at 1 m/s: the tool force at first touch is the law's
    (with 'spring' the dashpot takes |F_t| above mu F_n, with 'total' it is mu F_n)."""
    params = _params(limit)
    s, c = math.sin(TILT), math.cos(TILT)
    tris = 0.15 * np.array([[[-1, s, -c], [1, s, -c], [1, -s, c]],
                            [[-1, s, -c], [1, -s, c], [-1, -s, c]]])
    state = SimState.from_spheres((1.0001 * R * NORMAL)[None], np.array([R]), 0, params)
    engine = Engine(params, [], TriangleMesh(tris, 1))
    v_tool = np.array([0.0, 0.0, 1.0])
    while not engine.tool_force.any():  # step until the face first touches (fresh spring)
        state = engine.run(state, 1, lambda t: ToolPose(v_tool * t, v_tool))
    delta = R - float((state.positions[0] - v_tool * state.time) @ NORMAL)
    v_rel = -v_tool  # the sphere was at rest until this step's force
    f_n, f_t = _expected(params, delta, R, float(state.masses[0]), v_rel, NORMAL, 0, 1)
    tool_n = float(engine.tool_force @ NORMAL)
    np.testing.assert_allclose(tool_n, -f_n, rtol=1e-6)
    np.testing.assert_allclose(engine.tool_force - tool_n * NORMAL, -f_t, rtol=1e-6, atol=1e-12)
    ratio = np.linalg.norm(f_t) / (0.4 * f_n)
    assert ratio > 2.0 if limit == 'spring' else ratio == pytest.approx(1.0)


@pytest.mark.parametrize('limit', ['spring', 'total'])
def test_pair_kernel_applies_the_coulomb_limit(limit: str) -> None:
    """Two spheres grazing at 1 m/s: the pair force at first touch is the law's."""
    params = _params(limit)
    pos = np.array([[0.0, 0.0, 0.0], [2 * R * 1.0001, 0.0, 0.0]])
    vel = np.array([[0.3, 0.0, 1.0], [0.0, 0.0, 0.0]])
    state = SimState.from_spheres(pos, np.array([R, R]), 0, params, velocities=vel)
    engine = Engine(params, [])
    state = engine.run(state, 1)
    while not engine.forces[0][0].any():  # step until the spheres first touch (fresh spring)
        state = engine.run(state, 1)
    gap = state.positions[0] - state.positions[1]
    n = gap / np.linalg.norm(gap)
    delta = 2 * R - float(np.linalg.norm(gap))
    f_n, f_t = _expected(params, delta, R / 2, float(state.masses[0]) / 2, vel[0], n, 0, 0)
    np.testing.assert_allclose(engine.forces[0][0], f_n * n + f_t, rtol=1e-6, atol=1e-12)
    ratio = np.linalg.norm(f_t) / (0.4 * f_n)
    assert ratio > 2.0 if limit == 'spring' else ratio == pytest.approx(1.0)
