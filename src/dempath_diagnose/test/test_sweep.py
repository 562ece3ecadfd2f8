"""Sweeps on a real Dask scheduler started as separate processes, and a worker killed mid-run."""

from __future__ import annotations

import os
import shutil
import signal
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from dempath_diagnose.library.dask_processes import (
    DASK,
    Group,
    start_group,
    start_scheduler,
    stop_groups,
    wait_for_workers,
)
from dempath_diagnose.library.sweep import DaskSweep, local_layout


@dataclass(frozen=True)
class StoreTask:
    """Like a library run: skip if stored, else work ``seconds``, then store atomically."""

    path: Path
    seconds: float

    def __call__(self) -> str:
        if self.path.is_file():
            return 'kept'
        time.sleep(self.seconds)
        tmp = self.path.with_suffix('.tmp')
        tmp.write_text(f'{os.getpid()}\n')
        tmp.replace(self.path)
        return 'ran'


def shipped(tasks: list[StoreTask]) -> list[Callable[[], str]]:
    """The tasks as closures pickled by value (workers cannot import a test module)."""
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[StoreTask.__module__])
    return [lambda t=t: t() for t in tasks]


@pytest.fixture
def scheduler(tmp_path: Path) -> Iterator[tuple[str, list[Group]]]:
    """A `dask scheduler` and two single-thread `dask worker` processes; stopped after."""
    if not shutil.which(DASK):
        pytest.fail(f'{DASK}: the dask CLI is missing (pinned in requirements.txt)')
    proc, address = start_scheduler(tmp_path)
    procs = [proc]
    try:
        for k in range(2):
            procs.append(start_group([DASK, 'worker', address, '--nthreads', '1',
                                      '--no-dashboard', '--name', f'w{k}'],
                                     tmp_path / f'worker{k}.log'))
        yield address, procs
    finally:
        stop_groups(procs)


def test_sweep_on_a_scheduler_given_by_address(
        scheduler: tuple[str, list[Group]], tmp_path: Path) -> None:
    """Every task runs on the external cluster and reports done once."""
    address, _ = scheduler
    wait_for_workers(address, 2)
    tasks = [StoreTask(tmp_path / f'run{k}.txt', 0.1) for k in range(6)]
    finished: list[int] = []
    with DaskSweep(address) as sweep:
        sweep.run(shipped(tasks), lambda k, _v: finished.append(k))
    assert sorted(finished) == list(range(6))
    assert all(t.path.is_file() for t in tasks)


def test_killed_worker_is_retried_and_nothing_finished_is_lost(
        scheduler: tuple[str, list[Group]], tmp_path: Path) -> None:
    """A worker killed mid-run: its task is retried on the other worker; files already stored
    are kept untouched."""
    address, procs = scheduler
    wait_for_workers(address, 2)
    tasks = [StoreTask(tmp_path / f'run{k}.txt', 1.5) for k in range(4)]
    finished: list[int] = []
    with DaskSweep(address) as sweep:
        import threading

        runner = threading.Thread(target=sweep.run,
                                  args=(shipped(tasks), lambda k, _v: finished.append(k)))
        runner.start()
        deadline = time.monotonic() + 60
        while not any(t.path.is_file() for t in tasks) and time.monotonic() < deadline:
            time.sleep(0.05)
        first = {t.path: t.path.read_text() for t in tasks if t.path.is_file()}
        os.killpg(procs[1].pid, signal.SIGKILL)  # one worker dies while running a task
        runner.join(120)
    assert not runner.is_alive()
    assert sorted(finished) == [0, 1, 2, 3]
    assert all(t.path.is_file() for t in tasks)
    assert all(path.read_text() == text for path, text in first.items())


def test_local_layout_fills_the_cores_without_oversubscribing() -> None:
    """workers x numba threads = cores."""
    assert local_layout(cores=2) == (2, 1)
    assert local_layout(cores=8) == (2, 4)
    assert local_layout(cores=1) == (1, 1)
    assert local_layout(cores=8, workers=4) == (4, 2)



@dataclass(frozen=True)
class EnvTask:
    """Writes when it started and its worker's allocator / OpenMP settings to ``path``."""

    path: Path
    seconds: float

    def __call__(self) -> None:
        started = time.time()
        time.sleep(self.seconds)
        env = [os.environ.get(k, '-') for k in ('MALLOC_TRIM_THRESHOLD_', 'OMP_NUM_THREADS')]
        self.path.write_text(f'{started!r} {env[0]} {env[1]}')


def test_local_cluster_starts_tasks_in_the_order_given_with_the_engine_environment(
        tmp_path: Path) -> None:
    """One local worker runs the tasks in the order given (the library puts its longest runs
    first), without Dask's default MALLOC_TRIM_THRESHOLD_ (glibc would map and unmap every
    large array) and with OMP_NUM_THREADS = its numba threads."""
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[EnvTask.__module__])
    tasks = [EnvTask(tmp_path / f'task{k}.txt', 0.05 * (k % 3)) for k in range(8)]
    finished: list[int] = []
    with DaskSweep(workers=1) as sweep:
        sweep.run([lambda t=t: t() for t in tasks], lambda k, _v: finished.append(k))
    assert sorted(finished) == list(range(len(tasks)))
    reports = [t.path.read_text().split() for t in tasks]
    starts = [float(r[0]) for r in reports]
    assert starts == sorted(starts)
    threads = local_layout(workers=1)[1]
    assert {(r[1], r[2]) for r in reports} == {('-', str(threads))}


def kernel_threads() -> tuple[int, str]:
    """numba's thread count and layer in this process after a parallel kernel of the engine's
    kind has run (the engine imported first, as a library run does)."""
    import numba
    import numpy as np

    import dempath_sim.engine  # noqa: F401  (picks the threading layer)

    @numba.njit(parallel=True)
    def total(a: np.ndarray) -> float:
        s = 0.0
        for i in numba.prange(a.size):
            s += a[i]
        return s

    assert total(np.ones(64)) == 64.0
    return numba.get_num_threads(), numba.threading_layer()


def test_local_workers_do_not_oversubscribe_the_cores() -> None:
    """Each local worker runs its kernels on its share of the cores (workers x threads = cores)
    on the OpenMP layer, also after a sweep of another layout in the same process (dask wrote its
    thread count into this process's environment, which then won): the workers used to start
    numba with every core's thread (four threads on two cores, the library's runs slowing one
    another)."""
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[kernel_threads.__module__])
    n, threads = local_layout(workers=2)
    with DaskSweep(workers=1):  # a sweep before it with another layout (as in a long process)
        pass
    with DaskSweep(workers=2) as sweep:
        found = sweep.client.run(kernel_threads)
    assert len(found) == n
    assert set(found.values()) == {(threads, 'omp')}, found


def test_address_of_an_http_server_is_refused_at_once() -> None:
    """--scheduler pointing at an HTTP server: ClusterError naming it (the client used to hang)."""
    import http.server
    import threading

    from dempath_diagnose.errors import ClusterError

    server = http.server.ThreadingHTTPServer(('127.0.0.1', 0),
                                             http.server.SimpleHTTPRequestHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    address = f'tcp://127.0.0.1:{server.server_address[1]}'
    try:
        with pytest.raises(ClusterError, match=f'{address}: not a Dask scheduler'), \
                DaskSweep(address, timeout_s=1.0):
            pass
    finally:
        server.shutdown()
        server.server_close()
