"""Simulation sweeps through Dask: a local cluster sized for the machine, or a scheduler address.

Each task runs one library pass and returns its record through its future; the client stores it
(atomically) as it arrives, so a finished run is never lost and a worker needs no access to the
client's folders. A task whose worker dies is retried on another worker (``RETRIES``); a run
that fails for a reason that would fail it again returns the failure as its value
(:class:`~dempath_diagnose.library.store.RunFailure`) and is not retried. Local workers get
``NUMBA_NUM_THREADS`` so that workers x numba threads = cores (the engine's kernels are
numba-parallel).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from types import TracebackType
from typing import Any

from dempath.daskprobe import SchedulerProbeError, check_dask_scheduler
from dempath_diagnose.errors import ClusterError

logger = logging.getLogger(__name__)

RETRIES = 3  # attempts after a worker died or a task failed
CONNECT_TIMEOUT_S = 10.0  # waiting for a scheduler given by address [s]
PROBE_TIMEOUT_S = 5.0  # waiting for a Dask handshake from that address [s]
MAX_LOCAL_WORKERS = 2  # more processes than this only add memory on small machines


PRE_SPAWN = 'distributed.nanny.pre-spawn-environ'


def worker_environ(threads: int) -> dict[str, Any]:
    """Dask's pre-spawn environment of a local worker, for the engine.

    Dask's default sets ``OMP_NUM_THREADS=1`` (the engine's OpenMP threads would then be one,
    whatever ``NUMBA_NUM_THREADS``) and ``MALLOC_TRIM_THRESHOLD_=65536`` (glibc then maps and
    unmaps every array above 128 KiB: 15x the page faults; ``dempath_sim.engine.allocator``
    also undoes it from inside the process). None unsets a variable.

    ``NUMBA_NUM_THREADS`` goes here, before the worker process starts: numba is imported while
    the worker starts, before a nanny's ``env`` is applied, and sizes its thread pool from what
    it saw then. Passed as ``env`` alone (until 2026-11-28) each of the two workers ran its
    kernels on two threads, four on the two cores.
    """
    import dask

    environ = dict(dask.config.get(PRE_SPAWN, {}))
    environ.update({'OMP_NUM_THREADS': str(threads), 'NUMBA_NUM_THREADS': str(threads),
                    'MALLOC_TRIM_THRESHOLD_': None})
    return environ


@contextmanager
def _process_environ(values: dict[str, str]) -> Iterator[None]:
    """Set ``values`` in this process's environment for the block, then restore it.

    A nanny takes a pre-spawn variable from this process's environment when it is set here
    (dask lets the shell's value win) and writes the pre-spawn values into this environment when
    it spawns: a second sweep in one process (another worker count) got the first one's thread
    count. The sweep's own layout must win for the worker it starts.
    """
    before = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in before.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def local_layout(cores: int | None = None, workers: int = 0) -> tuple[int, int]:
    """(workers, numba threads per worker) with workers x threads = cores."""
    cores = cores or os.cpu_count() or 1
    n = workers or min(MAX_LOCAL_WORKERS, cores)
    n = max(1, min(n, cores))
    return n, max(1, cores // n)


class DaskSweep:
    """A Dask client on a scheduler address, or on a LocalCluster started here.

    Args:
        scheduler: ``tcp://host:port`` of a running scheduler; None for a local cluster.
        workers: Local workers (0: by cores).
        timeout_s: How long to try reaching a scheduler given by address [s].
    """

    def __init__(self, scheduler: str | None = None, workers: int = 0,
                 timeout_s: float = CONNECT_TIMEOUT_S) -> None:
        self.scheduler = scheduler
        self.workers = workers
        self.timeout_s = timeout_s
        self.client: Any = None
        self.cluster: Any = None

    def __enter__(self) -> DaskSweep:
        import dask
        from distributed import Client, LocalCluster

        if self.scheduler:
            try:  # within seconds, not a hang or an exabyte allocation on a wrong address
                check_dask_scheduler(self.scheduler, min(self.timeout_s, PROBE_TIMEOUT_S))
            except SchedulerProbeError as err:
                raise ClusterError(str(err)) from None
            try:
                with dask.config.set({'distributed.comm.timeouts.connect': self.timeout_s}):
                    self.client = Client(self.scheduler, timeout=self.timeout_s)
            except (OSError, TimeoutError) as err:
                msg = f'{self.scheduler}: cannot reach the Dask scheduler ({err})'
                raise ClusterError(msg) from err
            return self
        n, threads = local_layout(workers=self.workers)
        environ = worker_environ(threads)
        with dask.config.set({PRE_SPAWN: environ}), _process_environ(
                {k: str(v) for k, v in environ.items() if k.endswith('_NUM_THREADS')}):
            self.cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                        dashboard_address=None)
        self.client = Client(self.cluster)
        logger.info('local Dask cluster: %d workers x %d numba threads', n, threads)
        return self

    def __exit__(self, kind: type[BaseException] | None, err: BaseException | None,
                 tb: TracebackType | None) -> None:
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    @property
    def remote(self) -> bool:
        """Whether the workers may be on other machines (a scheduler given by address)."""
        return bool(self.scheduler)

    def run(self, tasks: Sequence[Callable[[], Any]], done: Callable[[int, Any], None]) -> None:
        """Run every task (retried when its worker dies), started in the order given;
        ``done(k, value)`` with what each returned, as each finishes.

        Raises:
            ClusterError: A task failed on every attempt (its message names the run).
        """
        from distributed import as_completed

        if not tasks:
            return
        futures = {self.client.submit(task, retries=RETRIES, pure=False,
                                      priority=len(tasks) - k): k  # in the order given
                   for k, task in enumerate(tasks)}
        failed: list[str] = []
        for future in as_completed(futures):
            k = futures[future]
            if future.status == 'error':
                failed.append(f'{tasks[k]!r:.80}: {future.exception()}')
            else:
                done(k, future.result())
                future.release()  # the record is stored: the worker may drop it
        if failed:
            raise ClusterError(f'{len(failed)} runs failed: {failed[0]}')
