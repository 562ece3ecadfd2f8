"""A missing, stale or partial library is built or completed, saying so and how long it takes."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
import yaml

from dempath_diagnose.cli import diagnose_main, library_notice
from dempath_diagnose.library.simulator import load_scene
from dempath_diagnose.library.store import Library, library_dir, library_state, recorded_run_s

from .conftest import SCENE, SPEC
from .test_hidden import case_files


def spec_args(root: Path, cache: Path) -> list[str]:
    """The CLI options that select the session's test library design under ``root``."""
    return ['--scene', SCENE, '--library-root', str(root), '--packing-cache',
            str(cache / 'packings'), '--seeds', ','.join(map(str, SPEC.seeds)),
            '--candidates', ','.join(SPEC.candidates), '--strengths', str(SPEC.n_strengths)]


def test_partial_library_is_completed_with_an_eta(cache: Path, tiny_library: Library,
                                                  tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """One run missing: 'partial (11 of 12 runs stored)', an ETA from the runs' recorded wall
    time, the one run made (a real tiny simulation), then the diagnosis."""
    root = tmp_path / 'library'
    folder = root / tiny_library.folder.name
    shutil.copytree(tiny_library.folder, folder)
    gone = folder / 'runs' / tiny_library.runs[-1].filename
    gone.unlink()
    scene = load_scene(SCENE)
    assert library_state(scene, SPEC, root)[:2] == ('partial', len(tiny_library.runs) - 1)
    markers, force = case_files(cache, 'tool_speed')
    argv = ['--measured', str(markers), '--force', str(force), '--out', str(tmp_path / 'out'),
            '--serial', *spec_args(root, cache)]
    assert diagnose_main(argv) == 0
    err = capsys.readouterr().err
    total = len(tiny_library.runs)
    assert f'the library is partial ({total - 1} of {total} runs stored); completing it: 1 ' \
        'simulations, about' in err, err
    assert re.search(r'\d+ s per run as recorded in \d+ earlier runs', err), err
    assert gone.is_file()
    assert library_state(scene, SPEC, root)[0] == 'ready'


def test_stale_library_is_named_with_an_eta(tiny_library: Library, tmp_path: Path) -> None:
    """The scene's physics changed (particle friction): its library is stale; the rebuild's ETA
    comes from the old library's recorded run times."""
    source = Path(str(load_scene(SCENE).source))
    raw = yaml.safe_load(source.read_text())
    raw['effects']['particle_friction'] = {'static_friction': 0.6, 'dynamic_friction': 0.5}
    changed_path = tmp_path / 'tiny_changed.yaml'
    changed_path.write_text(yaml.safe_dump(raw))
    changed = load_scene(str(changed_path))
    root = tmp_path / 'library'
    shutil.copytree(tiny_library.folder, root / tiny_library.folder.name)
    assert library_dir(changed, SPEC, root) != root / tiny_library.folder.name
    state, done, total = library_state(changed, SPEC, root)
    assert (state, done, total) == ('stale', 0, len(tiny_library.runs))
    per_run, timed = recorded_run_s(changed, SPEC, root)
    assert per_run > 0 and timed > 0
    line = library_notice(changed.name, state, done, total, per_run, timed, 2)
    assert line.startswith("tiny: the library is stale (the scene's physics changed")
    assert f'building it: {total} simulations, about' in line and '2 at a time' in line


def test_missing_library_says_so_and_an_unreachable_scheduler_is_one_line(
        cache: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """No library: the notice says it is missing and that the first run gives the ETA; the
    Dask scheduler nobody listens on is then one error line naming it; nothing is written."""
    markers, _ = case_files(cache, 'control')
    root = tmp_path / 'empty'
    out = tmp_path / 'out'
    code = diagnose_main(['--measured', str(markers), '--out', str(out), '--scheduler',
                          'tcp://127.0.0.1:9', *spec_args(root, cache)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert err[0].startswith('tiny: no signature library yet; building it: ')
    assert 'known after the first run' in err[0]
    errors = [line for line in err if line.startswith('error: ')]
    assert len(errors) == 1 and 'tcp://127.0.0.1:9' in errors[0], err
    assert not (out / 'diagnosis.json').exists()
