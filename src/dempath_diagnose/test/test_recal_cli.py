"""`dempath recalibrate` on the tiny scene: a hidden tool-speed case (seed the library never used)
fitted to the floor, the control left unchanged, and bad inputs as one clear line each."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dempath_diagnose.decision.diagnosis import CaseGeometry
from dempath_diagnose.library.simulator import load_scene
from dempath_diagnose.library.store import Library
from dempath_diagnose.recalibrate_cli import recalibrate_main

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
    paper = data['paper']  # Table 7 before and after, each beside the floor over seeds
    before, after, floor = paper['before'], paper['after'], paper['floor']
    assert len(before['markers']) == len(after['markers']) >= 10
    assert floor['seeds'] == len(SPEC.seeds) and floor['mean_nrmse_pct'] > 0
    assert {'marker', 'mae_mm', 'rmse_mm', 'range_mm', 'nrmse_pct'} <= set(after['markers'][0])
    assert all(np.isfinite(p['mean_nrmse_pct']) for p in (before, after, floor)), paper
    assert diag['error_after']['paper']['mean_nrmse_pct'] == after['mean_nrmse_pct']
    assert diag['error_after']['paper']['floor'] == floor
    assert diag['recalibration']['tool_speed']['strengths'][0]['uncertainty'] > 0
    report = (out / 'recalibration.md').read_text()
    assert 'Table 7 before' in report and 'trajectories.png' in report
    for name in ('recalibration.png', 'trajectories.png', 'recalibration.md'):
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
    (['--effect', 'tool_speed', '--also', 'cohesion'], '--also cohesion: the scene has this'),
    (['--effect', 'tool_speed', '--also', 'levitation'], '--also levitation: not a candidate'),
], ids=['unknown_effect', 'outside_range', 'budget_0', 'also_effect_off', 'also_unknown'])
def test_bad_input_is_one_line(cache: Path, tiny_library: Library, tmp_path: Path,
                               capsys: pytest.CaptureFixture[str], extra: list[str],
                               expected: str) -> None:
    code = recalibrate_main([*argv_for(cache, 'tool_speed', tmp_path / 'o'), *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and err[-1].startswith('error: ') and expected in err[-1], err


def test_unstable_candidate_is_scored_failed_and_the_loop_goes_on(
        cache: Path, tiny_library: Library, tmp_path: Path) -> None:
    """Cohesion at 1e6 J/m^3 blows the tiny bed up at once: that run is scored as failed, the
    next proposal moves back towards the scene's value, and the command ends normally."""
    out = tmp_path / 'unstable'
    argv = [*argv_for(cache, 'cohesion', out), '--effect', 'cohesion=1e6', '--budget', '3',
            '--seeds-per-eval', '1']
    assert recalibrate_main(argv) == 0
    data = json.loads((out / 'recalibration.json').read_text())
    steps = data['steps']
    assert data['failures'] >= 1 and steps[1]['note'].startswith('failed: ')
    assert 'blow-up' in steps[1]['note'] and steps[1]['error'] == float('inf')
    assert len(steps) >= 3 and steps[2]['strengths'][0] < steps[1]['strengths'][0]
    assert (out / 'tiny.recalibrated.yaml').is_file()


def test_inconclusive_tries_the_remaining_candidates_in_turn(
        cache: Path, tiny_library: Library, tmp_path: Path) -> None:
    """An inconclusive diagnosis (tool friction or tool speed): both are fitted in turn, the
    budget shared; the one that brings the error down (tool speed, the hidden one) is written."""
    diag = tmp_path / 'diagnosis.json'
    diag.write_text(json.dumps({'verdict': 'inconclusive', 'remaining': ['tool_friction',
                                                                         'tool_speed'],
                                'ranking': [{'effect': 'tool_friction'},
                                            {'effect': 'tool_speed'}]}))
    out = tmp_path / 'inconclusive'
    argv = [*argv_for(cache, 'tool_speed', out), '--diagnosis', str(diag), '--budget', '4']
    assert recalibrate_main(argv) == 0
    data = json.loads((out / 'recalibration.json').read_text())
    assert set(data['tried']) == {'tool_friction', 'tool_speed'}
    assert data['brings_error_down'] == 'tool_speed' and data['effect'] == 'tool_speed'
    assert all(v['simulations'] <= 2 for v in data['tried'].values())
    assert 'Candidates tried' in (out / 'recalibration.md').read_text()


def test_also_refits_tool_friction_beside_tool_speed(
        cache: Path, tiny_library: Library, tmp_path: Path) -> None:
    """--also: two strengths fitted together (CMA-ES), both written to the scene when changed,
    one more panel in the error-vs-iteration plot."""
    out = tmp_path / 'also'
    argv = [*argv_for(cache, 'tool_speed', out), '--effect', 'tool_speed', '--also',
            'tool_friction', '--budget', '4']
    assert recalibrate_main(argv) == 0
    data = json.loads((out / 'recalibration.json').read_text())
    names = [p['name'] for p in data['parameters']]
    assert names == ['tool_speed', 'tool_friction']
    assert all(len(s['strengths']) == 2 for s in data['steps'])
    assert data['changed'] and data['error_reduction'] >= 0.5, data
    scene = load_scene(str(out / 'tiny.recalibrated.yaml'))
    fitted = {p['name']: p for p in data['parameters']}
    assert scene.effects['tool_speed'].values['speed_scale'] == pytest.approx(
        fitted['tool_speed']['value'])
    assert scene.effects['tool_friction'].values['static_friction'] == pytest.approx(
        fitted['tool_friction']['value'])


def test_recalibration_from_a_packed_library(cache: Path, tiny_library: Library,
                                             geometry: CaseGeometry, tmp_path: Path) -> None:
    """A packed library (what the demo ships) has no run files: the 'before' runs of Table 7
    come from the loaded records, and the fit, the paper's metrics and the figures are written.
    As the demo does, markers 3, 8 and 13 are held out of the diagnosis and the fit and scored
    apart before and after; the loop is judged by the like-for-like d^2 band."""
    from dempath_diagnose.decision.measure import load_tracks
    from dempath_diagnose.library.packed import export_library

    markers, _ = case_files(cache, 'tool_speed')
    packed = tmp_path / 'lib.npz'
    export_library(tiny_library, packed, geometry.cube_m, load_tracks(markers).start)
    out = tmp_path / 'recal'
    argv = argv_for(cache, 'tool_speed', out)
    k = argv.index('--library-root')
    argv[k:k + 2] = ['--library', str(packed)]
    assert recalibrate_main([*argv, '--budget', '2', '--held-out', '3,8,13']) == 0
    data = json.loads((out / 'recalibration.json').read_text())
    assert data['effect'] == 'tool_speed' and data['changed'], data
    paper = data['paper']
    assert len(paper['before']['markers']) == len(paper['after']['markers']) >= 10
    held = paper['headline_held_out']
    assert held['markers'] == [3, 8, 13]
    assert held['after']['value_mm'] < held['before']['value_mm'], held
    assert set(held['before']['per_marker_mm']) == {'3', '8', '13'}
    diag = json.loads((out / 'diagnosis.json').read_text())
    assert diag['held_out'] == [3, 8, 13] and '8' not in diag['markers_in_windows']
    assert data['stopped_on'] == 'the like-for-like d^2 floor band', data['floor_bands']
    assert data['floor_bands'][0]['iteration'] == 0 and data['floor_bands'][0]['seeds'] == 3
    assert all(np.isfinite(paper[k]['mean_nrmse_pct']) for k in ('before', 'after', 'floor'))
    assert not paper['after_is_before']  # the after runs are the fitted model's own
    assert (out / 'trajectories.png').stat().st_size > 0
