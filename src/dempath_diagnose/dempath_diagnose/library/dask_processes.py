"""A Dask cluster made of separate `dask` processes on this machine, and stopping it cleanly.

A `dask scheduler` and `dask worker` processes started as their own process groups, as an
operator starts them on a cluster's hosts; the library's sweeps reach them through the
scheduler's address alone (`DaskSweep(address)`). The scale-out bench and the tests that kill a
worker mid-run, or give a worker no disk shared with the client, start their clusters here. A
worker may get its own HOME, TMPDIR and packing cache, and, where the machine allows a private
mount namespace, an empty tmpfs over a folder it must not see (as a worker on another host).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

DASK = str(Path(sys.executable).parent / 'dask')
"""The `dask` command of this environment (pinned with distributed in requirements.txt)."""

Group = subprocess.Popen[bytes]  # a process started as the leader of its own process group


def start_group(command: Sequence[str], log: Path) -> Group:
    """Start ``command`` as its own process group, its output (both streams) into ``log``."""
    return subprocess.Popen(list(command), stdout=log.open('wb'), stderr=subprocess.STDOUT,
                            start_new_session=True)


def start_scheduler(folder: Path, timeout_s: float = 60.0) -> tuple[Group, str]:
    """A `dask scheduler` on a free port; returns it and its address once it has written it.

    Raises:
        RuntimeError: the scheduler did not write its address within ``timeout_s``.
    """
    port_file = folder / 'scheduler.json'
    proc = start_group([DASK, 'scheduler', '--port', '0', '--no-dashboard', '--scheduler-file',
                        str(port_file)], folder / 'scheduler.log')
    deadline = time.monotonic() + timeout_s
    while not port_file.is_file():
        if proc.poll() is not None or time.monotonic() > deadline:
            stop_groups([proc])
            raise RuntimeError(f'{folder / "scheduler.log"}: the dask scheduler did not start')
        time.sleep(0.1)
    return proc, str(json.loads(port_file.read_text())['address'])


def namespaces_allowed(masked: Path) -> bool:
    """Whether this machine lets a process have its own mount namespace with a tmpfs over
    ``masked`` (root, or user namespaces allowed)."""
    if not shutil.which('unshare'):
        return False
    probe = subprocess.run(['unshare', '--mount', '--propagation', 'private', 'sh', '-c',
                            f'mount -t tmpfs tmpfs {masked}'], capture_output=True, check=False)
    return probe.returncode == 0


def lone_worker_command(address: str, home: Path, name: str,
                        masked: Path | None = None) -> list[str]:
    """A single-thread `dask worker` with its own HOME, TMPDIR, packing cache and folder
    (``home``), one numba thread; with ``masked``, inside its own mount namespace where that
    folder is an empty tmpfs."""
    run = (f'mkdir -p {home}/cache && cd {home} && HOME={home} TMPDIR={home} '
           f'DEMPATH_CACHE_DIR={home}/cache NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 '
           f'exec {DASK} worker {address} --nthreads 1 --no-dashboard --name {name}')
    if masked is None:
        return ['sh', '-c', run]
    return ['unshare', '--mount', '--propagation', 'private', 'sh', '-c',
            f'mount -t tmpfs tmpfs {masked} && {run}']


def wait_for_workers(address: str, n: int, timeout_s: float = 120.0) -> None:
    """Return once ``n`` workers have joined the scheduler at ``address``."""
    from distributed import Client

    with Client(address, timeout=30) as client:  # type: ignore[no-untyped-call]
        client.wait_for_workers(n, timeout=timeout_s)


def stop_groups(procs: Sequence[Group], grace_s: float = 10.0) -> None:
    """Stop the process groups (last started first): SIGTERM, then SIGKILL after ``grace_s``."""
    for p in reversed(procs):
        if p.poll() is None:
            try:
                os.killpg(p.pid, signal.SIGTERM)
                p.wait(grace_s)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
            except ProcessLookupError:
                pass
