"""Simulations on demand (issue 32) on the tiny scene: a tool speed past the library's span is
run past the edge and named with its value; a control spends nothing; budget 0 changes nothing."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import pytest

from dempath_diagnose.adaptive import probabilities, refine
from dempath_diagnose.decision.diagnosis import CaseGeometry, Diagnosis, diagnose
from dempath_diagnose.decision.measure import load_force, load_tracks
from dempath_diagnose.library.cases import HiddenCase, make_case
from dempath_diagnose.library.simulator import load_scene
from dempath_diagnose.library.store import EXTRA_RUNS, Library, extend_library, serial_executor
from dempath_diagnose.records import Measurement

from .conftest import SCENE, SPEC
from .test_hidden import case_files

FAST = HiddenCase('tool_speed_2', {'tool_speed.speed_scale': 2.0}, 'tool_speed',
                  ('parameter_off',), seed=13)


def _measurement(markers: Path, force: Path) -> Measurement:
    t, f = load_force(force)
    return replace(load_tracks(markers), force_times=t, force=f)


def _own_copy(library: Library, tmp_path: Path) -> Library:
    """A copy of the session library (the runs added here must not reach other tests)."""
    folder = tmp_path / 'library'
    shutil.copytree(library.folder, folder)
    return Library.load(folder)


def _refine(meas: Measurement, library: Library, geometry: CaseGeometry, budget: int,
            cache: Path) -> tuple[Diagnosis, Diagnosis, Library, object]:
    scene = load_scene(SCENE)

    def again(lib: Library) -> Diagnosis:
        return diagnose(meas, lib, geometry)

    def extend(lib: Library, additions: list[tuple[str, float]], seeds: int) -> Library:
        return extend_library(lib, scene, SPEC, additions, seeds, serial_executor,
                              cache / 'packings')

    first = again(library)
    final, grown, result = refine(first, library, again, extend, budget)
    return first, final, grown, result


@pytest.mark.timeout(1800)  # a guard, not a timing
def test_speed_past_the_span_is_run_and_named(cache: Path, tiny_library: Library,
                                              geometry: CaseGeometry, tmp_path: Path) -> None:
    """Tool speed x2 lies past the library's 0.6-1.5 (+ a quarter): the fit stops at the edge;
    the budget runs it past the edge, and the answer is parameter_off near 2."""
    markers, force = make_case(load_scene(SCENE), FAST, cache / 'cases' / FAST.name,
                               until_s=SPEC.duration_s, cache_dir=cache / 'packings')
    library = _own_copy(tiny_library, tmp_path)
    first, final, grown, result = _refine(_measurement(markers, force), library, geometry, 6,
                                          cache)
    top0 = first.decision.ranking[0]
    assert top0.name == 'tool_speed' and top0.at_range_edge, top0
    top = final.decision.ranking[0]
    assert final.decision.verdict == 'parameter_off' and top.name == 'tool_speed'
    assert not top.at_range_edge and abs(top.strength - 2.0) <= max(0.1, 2 * top.strength_sd)
    assert result.steps[0].runs[0].why == 'past_edge'  # type: ignore[attr-defined]
    assert result.steps[0].runs[0].strength > 1.5  # type: ignore[attr-defined]
    assert 0 < result.used <= 6  # type: ignore[attr-defined]
    assert result.steps[0].after['tool_speed'] >= 0.8  # type: ignore[attr-defined]
    assert len(grown.runs) == len(library.runs) + result.used  # type: ignore[attr-defined]
    assert (library.folder / EXTRA_RUNS).is_file()
    assert len(Library.load(library.folder).runs) == len(grown.runs)  # kept for the next case


@pytest.mark.timeout(600)
def test_control_spends_nothing_and_budget_zero_changes_nothing(
        cache: Path, tiny_library: Library, geometry: CaseGeometry, tmp_path: Path) -> None:
    """Nothing missing: the library already says so, so no simulation is run; budget 0 is
    today's diagnosis. The control's markers alone (its draft lies near tool friction's, so
    with the force the answer may be open: test_hidden)."""
    meas = load_tracks(case_files(cache, 'control')[0])
    library = _own_copy(tiny_library, tmp_path)
    first, final, _, result = _refine(meas, library, geometry, 6, cache)
    assert first.decision.verdict == 'nothing_significant'
    assert final.decision.verdict == 'nothing_significant'
    assert result.used == 0 and 'nothing missing' in result.stop  # type: ignore[attr-defined]
    _, same, _, zero = _refine(meas, library, geometry, 0, cache)
    assert zero.used == 0 and not zero.steps  # type: ignore[attr-defined]
    assert probabilities(same) == probabilities(first)
    assert same.decision.verdict == first.decision.verdict


@pytest.mark.timeout(1800)
def test_cli_budget_reports_what_it_ran(cache: Path, tiny_library: Library,
                                        tmp_path: Path) -> None:
    """``dempath diagnose --budget 3``: diagnosis.json says what was run, why and how the
    probabilities moved; report.md has the section; the runs stay in the library."""
    import json

    from dempath_diagnose.cli import diagnose_main

    root = tmp_path / 'libraries'
    shutil.copytree(tiny_library.folder, root / tiny_library.folder.name)
    markers, force = make_case(load_scene(SCENE), FAST, cache / 'cases' / FAST.name,
                               until_s=SPEC.duration_s, cache_dir=cache / 'packings')
    out = tmp_path / 'diag'
    assert diagnose_main(['--measured', str(markers), '--force', str(force), '--scene', SCENE,
                          '--out', str(out), '--library-root', str(root), '--packing-cache',
                          str(cache / 'packings'), '--seeds', ','.join(map(str, SPEC.seeds)),
                          '--candidates', ','.join(SPEC.candidates), '--strengths',
                          str(SPEC.n_strengths), '--serial', '--budget', '3']) == 0
    data = json.loads((out / 'diagnosis.json').read_text())
    adaptive = data['adaptive']
    assert adaptive['extra_simulations'] == 3 and adaptive['budget'] == 3
    (step,) = adaptive['steps']
    assert step['runs'][0]['why'] == 'past_edge' and 'edge of the library' in \
        step['runs'][0]['reason']
    assert step['before']['tool_speed'] > 0.5 and 'tool_speed' in step['after']
    assert adaptive['stop'].startswith(('the budget of simulations is spent',
                                        'tool_speed is named (p 1.00)'))
    assert data['simulations'] == len(tiny_library.runs) + 3
    assert '## Simulations beyond the library (3 of a budget of 3)' in \
        (out / 'report.md').read_text()
