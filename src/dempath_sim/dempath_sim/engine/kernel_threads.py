"""Which threads numba's parallel kernels run on: the threading layer and a thread limit.

The engine runs states of fewer than `Engine.SERIAL_BELOW` particles on one thread: waking a
second thread costs more than it saves there. With numba's TBB threading layer (picked when
libtbb is installed) the cost of a multi-threaded launch also grew with the number of launches
on the 2-core test machine under load (about 16 us to 440 us per launch of an empty kernel over
6,000 launches), while one-thread launches stay flat, so every kernel call of a small state,
also a direct `bind` or `contact_forces` call, goes through :func:`threads_at_most`.

The TBB layer's slowdown also hits long two-thread runs: a reduced-scene fill that takes about
3 min in a fresh process ran for over 30 min later in the same process, with the CPU time
spent in the kernel (100 % system time), and a process that made many TBB launches takes a
minute to exit. GNU OpenMP shows neither, so :func:`prefer_openmp_layer` picks it unless the
user chose a layer. The library's Dask workers ran TBB until 2026-11-28 (numba dropped the
choice when the nanny set NUMBA_NUM_THREADS): a worker's pair rate fell from 11 M/s to 1.6 M/s
over its first 30 min, which made a `reduced_1ms` library several times slower than it is.
"""

from __future__ import annotations

import importlib
import logging
import os
from collections.abc import Iterator
from contextlib import contextmanager

import numba

logger = logging.getLogger(__name__)


def prefer_openmp_layer() -> str:
    """Make numba's parallel kernels use its OpenMP threading layer where it can.

    Nothing changes when NUMBA_THREADING_LAYER is set (the user's choice wins) or when the
    OpenMP layer cannot be loaded (numba then picks TBB or its workqueue, as without this
    call). It acts before the first parallel launch of the process, which fixes the layer.

    Returns:
        The layer setting numba will use: ``'omp'`` or the setting left as it was.
    """
    if 'NUMBA_THREADING_LAYER' in os.environ:
        return str(numba.config.THREADING_LAYER)
    try:
        importlib.import_module('numba.np.ufunc.omppool')
    except ImportError as err:  # no GNU OpenMP runtime (libgomp) on this machine
        logger.debug('numba OpenMP layer unavailable (%s); keeping %s', err,
                     numba.config.THREADING_LAYER)
        return str(numba.config.THREADING_LAYER)
    # numba re-reads every NUMBA_* variable at each compile once one of them changed since its
    # import, and resets its settings from them: the choice goes into the environment too, or a
    # variable set later (a Dask nanny sets NUMBA_NUM_THREADS in its worker) undoes it
    os.environ['NUMBA_THREADING_LAYER'] = 'omp'
    numba.config.THREADING_LAYER = 'omp'
    return 'omp'


@contextmanager
def threads_at_most(n: int) -> Iterator[None]:
    """Run the enclosed numba kernels on at most n threads; numba's count is restored after.

    Args:
        n: Largest thread count (>= 1); nothing changes when numba's count is already <= n.
    """
    outer = numba.get_num_threads()
    if n >= outer:
        yield
        return
    numba.set_num_threads(n)
    try:
        yield
    finally:
        numba.set_num_threads(outer)
