"""numba's threads: the OpenMP layer the engine picks unless the user chose one, and the thread
limit around kernel calls (applied inside, restored after, also on an error)."""

from __future__ import annotations

import os
import subprocess
import sys

import numba
import numpy as np
import pytest

from dempath_sim.engine import Engine
from dempath_sim.engine.kernel_threads import threads_at_most
from dempath_sim.engine.state import SimState

from .mesh_setup import FLOOR, PARAMS, RADIUS


def test_threads_at_most_limits_and_restores() -> None:
    """Inside the block numba runs on min(n, its count) threads; the count is back after, also
    when the block raises, and a limit above the count changes nothing."""
    outer = numba.get_num_threads()
    with threads_at_most(1):
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == outer
    with pytest.raises(ValueError, match='inside'), threads_at_most(1):
        raise ValueError('inside')
    assert numba.get_num_threads() == outer
    with threads_at_most(outer + 1):
        assert numba.get_num_threads() == outer


def test_small_state_forces_do_not_change_the_thread_count() -> None:
    """bind and a direct contact_forces call on a one-sphere state (kernels limited to one
    thread) leave numba's thread count as they found it and give the floor's Hertz force."""
    outer = numba.get_num_threads()
    overlap = 2.0e-5  # m
    state = SimState.from_spheres(np.array([[0.0, RADIUS - overlap, 0.0]]), RADIUS, 0, PARAMS)
    engine = Engine(PARAMS, walls=FLOOR)
    engine.bind(state)
    engine.contact_forces(state, engine.tool_pose, dt=0.0)
    assert numba.get_num_threads() == outer
    grain, steel = PARAMS.materials
    e_star = 1.0 / ((1 - grain.poisson_ratio**2) / grain.youngs_modulus
                    + (1 - steel.poisson_ratio**2) / steel.youngs_modulus)
    hertz = 4.0 / 3.0 * e_star * np.sqrt(RADIUS) * overlap**1.5  # N
    np.testing.assert_allclose(engine.forces[0][0], [0.0, hertz, 0.0], rtol=1e-9, atol=1e-12)


LAYER_PROBE = """
import numba, numpy as np
import dempath_sim.engine
@numba.njit(parallel=True)
def total(a):
    s = 0.0
    for i in numba.prange(a.size):
        s += a[i]
    return s
assert total(np.ones(64)) == 64.0
print(numba.threading_layer())
"""


@pytest.mark.parametrize(('setting', 'expected'), [(None, 'omp'), ('workqueue', 'workqueue')])
def test_engine_picks_openmp_unless_the_user_chose(setting: str | None, expected: str) -> None:
    """A fresh process that imports the engine runs parallel kernels on numba's OpenMP layer;
    a NUMBA_THREADING_LAYER the user set wins."""
    env = {k: v for k, v in os.environ.items() if k != 'NUMBA_THREADING_LAYER'}
    if setting is not None:
        env['NUMBA_THREADING_LAYER'] = setting
    out = subprocess.run([sys.executable, '-c', LAYER_PROBE], env=env, capture_output=True,
                         text=True, timeout=300, check=True)
    assert out.stdout.split()[-1] == expected


ENV_CHANGE_PROBE = LAYER_PROBE.replace(  # a variable set after the import, as a Dask nanny does
    'import dempath_sim.engine\n',
    "import dempath_sim.engine\nimport os\nos.environ['NUMBA_NUM_THREADS'] = '1'\n")


def test_openmp_survives_a_numba_variable_set_later() -> None:
    """numba re-reads every NUMBA_* variable when one changed since it was imported (at each
    compile) and resets its settings from them: the OpenMP choice must survive that. Without it
    the library's Dask workers ran TBB, whose launches grew dearer through a run (a worker's pair
    rate fell from 11 M/s to 1.6 M/s over 30 min, 2026-11-28)."""
    env = {k: v for k, v in os.environ.items()
           if k not in ('NUMBA_THREADING_LAYER', 'NUMBA_NUM_THREADS')}
    assert 'NUMBA_NUM_THREADS' in ENV_CHANGE_PROBE
    out = subprocess.run([sys.executable, '-c', ENV_CHANGE_PROBE], env=env, capture_output=True,
                         text=True, timeout=300, check=True)
    assert out.stdout.split()[-1] == 'omp'
