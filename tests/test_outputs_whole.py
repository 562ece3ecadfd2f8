"""Run folders are written whole: a killed ``dempath simulate`` leaves nothing a reader accepts.

The reproduction of issue 27 (a rerun into an existing folder, SIGKILLed while ``model.csv`` is
written, left the new truncated CSV beside the old ``summary.json`` and ``dempath compare``
scored it with exit 0) is replayed with real processes killed at many moments.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from dempath.errors import OutputError
from dempath.outputs import WRITING_MARKER, check_output_folder, staged_output
from dempath_compare.cli import compare_main
from dempath_sim.cli import write_run_folder
from dempath_sim.runs.markers import ROLE_CANDIDATE, ROLE_MARKER
from dempath_sim.runs.results import SimResult

WRITER = """
import sys
from pathlib import Path
sys.path.insert(0, {here!r})
from test_outputs_whole import synthetic_result
from dempath_sim.cli import write_run_folder
write_run_folder(synthetic_result(int(sys.argv[2]), int(sys.argv[3])), Path(sys.argv[1]))
"""


def synthetic_result(seed: int, frames: int = 40) -> SimResult:
    """A run record of 15 markers with 20 candidates each on random walks (metres)."""
    rng = np.random.default_rng(seed)
    markers = np.repeat(np.arange(1, 16, dtype=np.int32), 21)
    roles = np.tile(np.r_[ROLE_MARKER, np.full(20, ROLE_CANDIDATE)].astype(np.uint8), 15)
    n = len(markers)
    steps = rng.normal(0.0, 1e-3, (frames, n, 3))
    positions = rng.uniform(-0.1, 0.1, (1, n, 3)) + np.cumsum(steps, axis=0)
    return SimResult(
        times=np.arange(frames) * 0.01, ids=np.arange(n, dtype=np.int64), roles=roles,
        marker_ids=markers, radii=np.full(n, 0.004), positions=positions,
        velocities=np.zeros((frames, n, 3)), tool_position=np.zeros((frames, 3)),
        tool_force=np.zeros((frames, 3)), tool_torque=np.zeros((frames, 3)),
        meta={'run_id': f'synthetic-s{seed}', 'seed': seed, 'scene': 'synthetic'})


def test_new_folder_appears_whole(tmp_path: Path) -> None:
    """A new output folder appears by one rename, with the manifest listing each file."""
    out = tmp_path / 'run'
    write_run_folder(synthetic_result(1), out)
    summary = json.loads((out / 'summary.json').read_text())
    assert set(summary['files']) == {'model.csv', 'markers.csv', 'tool.csv', 'result.npz'}
    assert sorted(p.name for p in tmp_path.iterdir()) == ['run']
    check_output_folder(out, 'summary.json')


def test_failed_run_leaves_no_folder(tmp_path: Path) -> None:
    """An error while writing leaves neither ``--out`` nor the staging folder behind."""
    out = tmp_path / 'run'
    with pytest.raises(RuntimeError), staged_output(out, 'summary.json') as stage:
        (stage / 'model.csv').write_text('t,id,x,y,z\n')
        raise RuntimeError('stopped')
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize('stop_after', [0, 1, 2, 3, 4])
def test_install_stopped_at_each_step_is_refused_or_whole(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, stop_after: int) -> None:
    """A rerun stopped after any number of file moves leaves a folder that is either refused
    or entirely the new run."""
    out = tmp_path / 'run'
    write_run_folder(synthetic_result(1), out)
    real_replace, moved = os.replace, []

    def replace_then_die(src: str | Path, dst: str | Path) -> None:
        if len(moved) == stop_after:
            raise KeyboardInterrupt
        moved.append(dst)
        real_replace(src, dst)

    monkeypatch.setattr(os, 'replace', replace_then_die)
    with pytest.raises(KeyboardInterrupt):
        write_run_folder(synthetic_result(2), out)
    monkeypatch.setattr(os, 'replace', real_replace)
    with pytest.raises(OutputError, match='incomplete outputs'):
        check_output_folder(out, 'summary.json')


def test_file_of_another_run_is_refused(tmp_path: Path) -> None:
    """A manifest whose file sizes do not match (a file swapped or cut short) is refused."""
    out = tmp_path / 'run'
    write_run_folder(synthetic_result(1), out)
    text = (out / 'model.csv').read_text()
    (out / 'model.csv').write_text(text[:len(text) // 3])
    with pytest.raises(OutputError, match=r'model\.csv: has \d+ bytes but summary.json lists'):
        check_output_folder(out, 'summary.json')


def killed_rerun(out: Path, seed: int, delay_s: float) -> bool:
    """Rerun a big write into ``out`` in a process SIGKILLed after ``delay_s``; True if it
    finished before the kill."""
    here = str(Path(__file__).parent)
    proc = subprocess.Popen([sys.executable, '-c', WRITER.format(here=here), str(out),
                             str(seed), '400'])
    time.sleep(delay_s)
    proc.send_signal(signal.SIGKILL)
    return proc.wait() == 0


def test_sigkilled_reruns_never_give_a_mixed_folder(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """Reruns SIGKILLed at spread-out moments leave the old run, the new run or a refused
    folder; ``dempath compare`` never scores a mix (exit 1 and one line when refused)."""
    out, measured = tmp_path / 'run', tmp_path / 'measured'
    write_run_folder(synthetic_result(1, 400), out)
    write_run_folder(synthetic_result(9, 40), measured)
    outcomes = set()
    for k, delay in enumerate(np.linspace(0.3, 6.0, 8)):
        killed_rerun(out, 100 + k, float(delay))
        try:
            check_output_folder(out, 'summary.json')
        except OutputError:
            outcomes.add('refused')
            code = compare_main([str(measured / 'markers.csv'), str(out), '--out',
                                 str(tmp_path / f'cmp{k}'), '--no-plots'])
            err = capsys.readouterr().err.strip().splitlines()
            assert code == 1 and len(err) == 1 and str(out) in err[0], err
            continue
        summary = json.loads((out / 'summary.json').read_text())
        seed = summary['seed']
        back = SimResult.load_npz(out / 'result.npz')
        assert back.meta['seed'] == seed
        outcomes.add('whole')
        assert WRITING_MARKER not in os.listdir(out)
    assert outcomes, 'no rerun was observed'
