"""Runs that must end: an unstable `dempath simulate` (one error line, exit 1), a stopped fill."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
from pathlib import Path

import pytest
import yaml

from dempath_sim.cli import simulate_main
from dempath_sim.errors import RunStoppedError
from dempath_sim.runs import RunOptions, run_scene
from dempath_sim.runs.bed import bundled_packing_dir, packing_key
from dempath_sim.scene import SCENES_DIR, load_scene, resolve_scene

EXIT_TIMEOUT_S = 120.0  # the run takes ~5-10 s; beyond this the process hangs


def _drain(fd: int, sink: list[bytes]) -> None:
    """Read the pseudo-terminal until the child closes it (keeps the child from blocking)."""
    while True:
        try:
            chunk = os.read(fd, 4096)
        except OSError:  # EIO once the child side is closed
            return
        if not chunk:
            return
        sink.append(chunk)


def _run_on_tty(argv: list[str]) -> tuple[int, str, str]:
    """Run `python -m dempath.cli ARGV` with stdout on a pseudo-terminal (live progress bar)
    and 2 numba threads; returns (exit code, stdout, stderr). Fails if it does not end."""
    master, slave = os.openpty()
    env = {**os.environ, 'NUMBA_NUM_THREADS': '2', 'COLUMNS': '120'}
    proc = subprocess.Popen([sys.executable, '-m', 'dempath.cli', *argv], stdin=subprocess.DEVNULL,
                            stdout=slave, stderr=subprocess.PIPE, env=env)
    os.close(slave)
    out: list[bytes] = []
    reader = threading.Thread(target=_drain, args=(master, out), daemon=True)
    reader.start()
    try:
        _, err = proc.communicate(timeout=EXIT_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail(f'dempath simulate {argv}: still running after {EXIT_TIMEOUT_S} s')
    finally:
        reader.join(timeout=5.0)
        os.close(master)
    return proc.returncode, b''.join(out).decode(errors='replace'), err.decode(errors='replace')


@pytest.mark.parametrize(('overlap_limit', 'extra'), [
    (1e-4, []),  # the settled bed already overlaps more: stops at the start of the drive
    (0.15, ['--effect', 'tool_speed.speed_scale=4']),  # stops once the tool squeezes grains
])
def test_overlap_error_ends_the_process(overlap_limit: float, extra: list[str],
                                        tmp_path: Path) -> None:
    """On the bundled 45k-sphere reduced bed (parallel path, progress bar on a terminal) an
    overlap beyond the limit prints one `error:` line and exits with 1 instead of running on."""
    data = yaml.safe_load((SCENES_DIR / 'reduced_1ms.yaml').read_text())
    data['sim']['max_overlap_fraction'] = overlap_limit
    data['tool']['settle_s'] = 0.0  # no re-settle: the limit is met in the drive itself
    scene_file = tmp_path / 'unstable.yaml'
    scene_file.write_text(yaml.safe_dump(data))
    scene = load_scene(scene_file)
    key = packing_key(scene, scene.physics_model())
    assert (bundled_packing_dir() / f'{key}.npz').is_file(), 'the bundled reduced bed is stale'
    code, out, err = _run_on_tty(['simulate', str(scene_file), '--out', str(tmp_path / 'out'),
                                  '--cache-dir', str(tmp_path / 'cache'), *extra])
    lines = err.strip().splitlines()
    errors = [line for line in lines if line.startswith('error:')]
    assert code == 1, f'exit code {code}; stderr: {err[-2000:]}'
    assert len(errors) == 1, f'expected one error line, got: {lines}'
    assert 'exceeds SimParams.max_overlap_fraction' in errors[0]
    assert 'stable dt <=' in errors[0] and 'Traceback' not in err
    assert not (tmp_path / 'out' / 'summary.json').exists()
    t_error = float(re.search(r' at t = (\S+) s', errors[0]).group(1))  # type: ignore[union-attr]
    if extra:
        assert t_error > 0.0, 'the error must come from the drive, between parallel steps'
        assert 'drive' in out, 'the progress bar must have been live on the terminal'
    else:
        assert t_error == 0.0


def test_builtin_prefix_names_a_shipped_scene(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """`builtin:NAME` loads the shipped scene NAME; an unknown name gives one error line."""
    assert resolve_scene('builtin:tiny') == resolve_scene('tiny')
    assert simulate_main(['builtin:no_such', '--out', str(tmp_path), '--quiet']) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('error: ') and 'no bundled scene' in err[0]


def test_stop_during_the_fill_ends_the_run(tmp_path: Path) -> None:
    """A stop request during the fill (a node shutting down) ends the run at the next settling
    check with RunStoppedError instead of settling the whole bed first."""
    stop = threading.Event()
    seen: list[str] = []

    def progress(p: object) -> None:
        seen.append(getattr(p, 'phase', ''))
        stop.set()  # ask to stop as soon as the fill reports

    options = RunOptions(cache_dir=tmp_path / 'cache', progress=progress, stop=stop)
    with pytest.raises(RunStoppedError, match='stopped during the fill'):
        run_scene(resolve_scene('tiny'), options)
    assert seen == ['fill'], 'exactly one settling check may run after the request'
    assert not any((tmp_path / 'cache').glob('*.npz')), 'no packing from a stopped fill'
