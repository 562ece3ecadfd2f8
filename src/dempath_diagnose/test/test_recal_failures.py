"""`dempath recalibrate` when things go wrong, on the tiny scene: the scheduler disappears
mid-sweep (a real `dask scheduler` and worker, separate processes), Ctrl-C (a real SIGINT to
the command), a candidate that drives the simulation unstable. Each gives one clear line, keeps
what was computed, and writes the best scene so far."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
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
from dempath_diagnose.library.store import Library
from dempath_diagnose.recalibrate_cli import recalibrate_main

from .test_recal_cli import argv_for


def _default_sigint() -> None:
    """In the child: SIGINT back to its default (a shell running the suite in the background
    starts it ignored, and a process that inherits that ignores Ctrl-C)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)



@pytest.fixture
def one_worker(tmp_path: Path) -> Iterator[tuple[str, list[Group]]]:
    """A `dask scheduler` and one single-thread `dask worker` (runs one after the other)."""
    proc, address = start_scheduler(tmp_path)
    procs = [proc]
    try:
        procs.append(start_group([DASK, 'worker', address, '--nthreads', '1', '--no-dashboard'],
                                 tmp_path / 'worker.log'))
        yield address, procs
    finally:
        stop_groups(procs)


def _when_a_run_is_stored(runs: Path, timeout_s: float = 1200.0) -> list[Path]:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        found = sorted(runs.glob('*.npz')) if runs.is_dir() else []
        found = [p for p in found if '.tmp' not in p.name]
        if found:
            return found
        time.sleep(0.1)
    raise AssertionError(f'{runs}: no run stored within {timeout_s:.0f} s')


@pytest.mark.timeout(1800)  # a guard, not a timing: the whole command runs twice
def test_scheduler_lost_mid_sweep_keeps_runs_and_a_rerun_resumes(
        cache: Path, tiny_library: Library, tmp_path: Path,
        one_worker: tuple[str, list[Group]],
        capsys: pytest.CaptureFixture[str]) -> None:
    """The scheduler killed after the first of two runs: one error line, the stored run kept,
    the best scene so far written; a rerun on the same --out does not redo the stored run."""
    import threading

    address, procs = one_worker
    wait_for_workers(address, 1)
    out = tmp_path / 'recal'
    argv = [a for a in argv_for(cache, 'tool_speed', out) if a != '--serial']
    stored: list[Path] = []

    def kill_scheduler() -> None:
        stored.extend(_when_a_run_is_stored(out / 'runs'))
        os.killpg(procs[0].pid, signal.SIGKILL)

    killer = threading.Thread(target=kill_scheduler, daemon=True)
    killer.start()
    code = recalibrate_main([*argv, '--scheduler', address, '--budget', '4', '--effect',
                             'tool_speed'])
    killer.join(5)
    text = capsys.readouterr().err
    err = [line for line in text.splitlines() if line.startswith('error')]
    assert code == 1 and len(err) == 1 and 'lost mid-sweep' in err[0], err
    assert 'Traceback' not in text, text
    data = json.loads((out / 'recalibration.json').read_text())
    assert data['stop'] == 'scheduler_lost'
    assert (out / 'tiny.recalibrated.yaml').is_file()
    kept = {p: p.stat().st_mtime_ns for p in stored}
    assert all(p.is_file() for p in kept)
    assert recalibrate_main([*argv, '--serial', '--budget', '4', '--effect', 'tool_speed']) == 0
    assert {p: p.stat().st_mtime_ns for p in kept} == kept  # resumed, not redone
    data = json.loads((out / 'recalibration.json').read_text())
    assert data['stop'] != 'scheduler_lost' and data['simulations'] >= 2


@pytest.mark.timeout(1800)  # a guard, not a timing: a fresh process imports and diagnoses
def test_ctrl_c_writes_the_best_scene_so_far(cache: Path, tiny_library: Library,
                                             tmp_path: Path) -> None:
    """SIGINT to a running `dempath recalibrate` during its first simulation (after the
    starting record, iteration 0, so that a quick fit cannot finish first): it stops with one
    line, recalibration.json says interrupted, the scene with the best strength so far is
    written."""
    out = tmp_path / 'recal'
    argv = [*argv_for(cache, 'cohesion', out), '--budget', '8', '--seeds-per-eval', '1',
            '--effect', 'cohesion']
    code = 'import sys; from dempath_diagnose.recalibrate_cli import recalibrate_main as m; ' \
           'sys.exit(m(sys.argv[1:]))'
    proc = subprocess.Popen([sys.executable, '-c', code, *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=_default_sigint)
    assert proc.stderr is not None
    lines = []
    for line in proc.stderr:
        lines.append(line)
        if 'iteration 0:' in line:  # at once: a tiny simulation can finish within a second
            proc.send_signal(signal.SIGINT)
            break
    stdout, rest = proc.communicate(timeout=1200)
    assert proc.returncode == 130, (stdout, ''.join(lines) + rest)
    assert 'Traceback' not in rest, rest
    if 'before the fit started' in rest:  # the signal beat the first simulation: one line
        errors = [line for line in rest.splitlines() if line.startswith('error')]
        assert len(errors) == 1 and 'interrupted (Ctrl-C)' in errors[0], rest
        return
    assert 'interrupted (Ctrl-C)' in stdout, (stdout, rest)
    data = json.loads((out / 'recalibration.json').read_text())
    assert data['stop'] == 'interrupted'
    best = min(s['error'] for s in data['steps'])
    assert data['error_after'] == pytest.approx(best)
    scene = (out / 'tiny.recalibrated.yaml').read_text()
    assert 'Recalibrated by dempath recalibrate' in scene
    if data['changed']:
        assert 'cohesion' in scene
