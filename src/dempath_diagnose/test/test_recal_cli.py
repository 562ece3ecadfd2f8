"""`dempath recalibrate` on the tiny scene: a hidden tool-speed case (seed the library never used)
fitted to the floor, the control left unchanged, and bad inputs as one clear line each."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from dempath_diagnose.library import Library
from dempath_diagnose.recal_cli import recalibrate_main
from dempath_diagnose.simulate import load_scene

from .conftest import SCENE, SPEC
from .test_hidden import CASES, case_files


def argv_for(cache: Path, name: str, out: Path) -> list[str]:
    markers, force = case_files(cache, name)
    return ['--measured', str(markers), '--force', str(force), '--scene', SCENE, '--out',
            str(out), '--library-root', str(cache / 'library'), '--packing-cache',
            str(cache / 'packings'), '--seeds', ','.join(map(str, SPEC.seeds)),
            '--candidates', ','.join(SPEC.candidates), '--strengths', str(SPEC.n_strengths),
            '--serial']


def test_hidden_tool_speed_is_fitted(cache: Path, tiny_library: Library, tmp_path: Path) -> None:
    """At least half the error above the floor removed; the hidden speed within 2 sd; outputs."""
    out = tmp_path / 'recal'
    assert recalibrate_main([*argv_for(cache, 'tool_speed', out), '--budget', '6']) == 0
    data = json.loads((out / 'recalibration.json').read_text())
    assert data['effect'] == 'tool_speed' and data['changed']
    assert data['error_reduction'] >= 0.5, data
    s = data['strength']
    hidden = CASES['tool_speed'].overrides['tool_speed.speed_scale']
    assert abs(s['value'] - hidden) <= 2 * s['uncertainty'] + 1e-9, s
    assert data['simulations'] <= 6
    scene = load_scene(str(out / 'tiny.recalibrated.yaml'))
    assert scene.effects['tool_speed'].values['speed_scale'] == pytest.approx(s['value'])
    head = (out / 'tiny.recalibrated.yaml').read_text().splitlines()[:3]
    assert any('tool_speed.speed_scale' in line for line in head)
    diag = json.loads((out / 'diagnosis.json').read_text())
    assert diag['error_after']['d2'] == pytest.approx(data['error_after'])
    for name in ('recalibration.png', 'recalibration.md'):
        assert (out / name).stat().st_size > 0


def test_control_changes_nothing(cache: Path, tiny_library: Library, tmp_path: Path,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'control'
    assert recalibrate_main(argv_for(cache, 'control', out)) == 0
    data = json.loads((out / 'recalibration.json').read_text())
    assert not data['changed'] and data['simulations'] == 0
    assert 'nothing changed' in capsys.readouterr().out


@pytest.mark.parametrize(('extra', 'expected'), [
    (['--effect', 'levitation'], '--effect levitation: not a candidate'),
    (['--effect', 'tool_speed=50'], 'outside the physical range'),
    (['--budget', '0'], '--budget 0: must be a positive'),
])
def test_bad_input_is_one_line(cache: Path, tiny_library: Library, tmp_path: Path,
                               capsys: pytest.CaptureFixture[str], extra: list[str],
                               expected: str) -> None:
    code = recalibrate_main([*argv_for(cache, 'tool_speed', tmp_path / 'o'), *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and err[-1].startswith('error: ') and expected in err[-1], err
