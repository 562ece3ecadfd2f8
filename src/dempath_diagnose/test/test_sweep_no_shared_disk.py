"""Sweeps through a real `dask scheduler` whose worker shares no folder with the client.

The worker runs in its own mount namespace with an empty tmpfs over the test folders (``pytest-
of-<user>``, where the client's library and packing cache live), its own HOME, TMPDIR, packing
cache and working folder, as a worker on another host has. Where the machine does not allow a mount
namespace, the worker still gets its own HOME, TMPDIR, cache and folder, and the check that it
cannot see the client's folder is skipped. A library build and a recalibration finish, the records
reach the client through the futures, the pour's bed travels back and forth, and a run that fails
for a reason that would fail it again is returned once, not retried.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from dempath_diagnose.cli import diagnose_main
from dempath_diagnose.library.dask_processes import (
    lone_worker_command,
    namespaces_allowed,
    start_group,
    start_scheduler,
    stop_groups,
    wait_for_workers,
)
from dempath_diagnose.library.simulator import load_scene
from dempath_diagnose.library.store import Library, LibrarySpec, LibraryTask, RunFailure, RunSpec
from dempath_diagnose.recalibrate_cli import recalibrate_main
from dempath_sim.runs.portable import pack_scene

from .conftest import SCENE
from .test_hidden import case_files
from .test_recal_cli import argv_for


def _masked_folder(basetemp: Path) -> Path:
    """The folder the worker must not see: every test's temporary folder (``pytest-of-<user>``),
    not all of /tmp, which may hold the checkout and its venv (a CI clone under /tmp)."""
    return next((p for p in basetemp.parents if p.name.startswith('pytest-of-')), basetemp)


@pytest.fixture(scope='module')
def lone_worker(tmp_path_factory: pytest.TempPathFactory,
                ) -> Iterator[tuple[str, bool]]:
    """(scheduler address, whether the worker's /tmp is its own): a `dask scheduler` and one
    single-thread `dask worker` without the client's disk."""
    tmp = tmp_path_factory.mktemp('lone')
    masked = _masked_folder(tmp_path_factory.getbasetemp())
    isolated = namespaces_allowed(masked)
    home = masked / 'worker-home' if isolated else tmp / 'worker-home'
    proc, address = start_scheduler(tmp)
    procs = [proc]
    try:
        procs.append(start_group(lone_worker_command(address, home, 'lone',
                                                     masked if isolated else None),
                                 tmp / 'worker.log'))
        wait_for_workers(address, 1)
        yield address, isolated
    finally:
        stop_groups(procs)


def _worker_sees(address: str, path: Path) -> bool:
    from distributed import Client

    with Client(address, timeout=30) as client:
        return any(client.run(os.path.exists, str(path)).values())


@pytest.mark.timeout(1800)  # a guard, not a timing: two pours and four tiny runs on one worker
def test_library_builds_on_a_worker_without_the_client_disk(
        lone_worker: tuple[str, bool], cache: Path, tmp_path: Path) -> None:
    """The worker pours the bed and runs the library; the bed and the records come back to the
    client's folders, which the worker cannot see."""
    address, isolated = lone_worker
    client = tmp_path / 'client'
    client.mkdir()
    if isolated:
        assert not _worker_sees(address, client)
    markers, force = case_files(cache, 'cohesion')
    out = client / 'diag'
    argv = ['--measured', str(markers), '--force', str(force), '--scene', SCENE,
            '--out', str(out), '--library-root', str(client / 'library'),
            '--packing-cache', str(client / 'packings'), '--seeds', '1001,1002',
            '--candidates', 'cohesion', '--strengths', '1', '--scheduler', address]
    assert diagnose_main(argv) == 0
    runs = sorted((client / 'library').glob('*/runs/*.npz'))
    assert [p.name for p in runs] == ['baseline-s1001.npz', 'baseline-s1002.npz',
                                      'cohesion@100000-s1001.npz', 'cohesion@100000-s1002.npz']
    assert len(list((client / 'packings').glob('*.npz'))) == 2  # the worker's pours came back
    data = json.loads((out / 'diagnosis.json').read_text())
    assert data['simulations'] == 4 and data['ranking'][0]['effect'] == 'cohesion'


@pytest.mark.timeout(1800)
def test_recalibration_evaluates_on_a_worker_without_the_client_disk(
        lone_worker: tuple[str, bool], cache: Path, tiny_library: Library,
        tmp_path: Path) -> None:
    """The recalibration's real evaluations run on the worker and are stored on the client."""
    address, isolated = lone_worker
    out = tmp_path / 'recal'
    argv = [a for a in argv_for(cache, 'tool_speed', out) if a != '--serial']
    assert recalibrate_main([*argv, '--scheduler', address, '--budget', '2',
                             '--seeds-per-eval', '1']) == 0
    data = json.loads((out / 'recalibration.json').read_text())
    assert data['effect'] == 'tool_speed' and 1 <= data['simulations'] <= 2
    stored = sorted((out / 'runs').glob('recal-*.npz'))
    assert len(stored) == data['simulations']
    if isolated:
        assert not _worker_sees(address, out)


def test_a_run_that_would_fail_again_is_returned_not_retried(
        lone_worker: tuple[str, bool]) -> None:
    """A run with an impossible strength comes back once as a RunFailure naming it."""
    from distributed import Client

    address, _ = lone_worker
    scene = load_scene(SCENE)
    run = RunSpec('cohesion@-5', 1001, 'cohesion', -5.0,
                  {'cohesion.energy_density_j_m3': -5.0})
    task = LibraryTask(pack_scene(scene), run, LibrarySpec(seeds=(1001,)), None)
    with Client(address, timeout=30) as client:
        future = client.submit(task, retries=3, pure=False)
        value = future.result(timeout=300)
        assert future.status == 'finished'  # no exception: nothing for Dask to retry
    assert isinstance(value, RunFailure) and value.label == 'cohesion@-5-s1001.npz'
    assert 'energy_density_j_m3' in value.message
