"""Separating two rival answers on demand (issue 32) on the tiny scene's test library: doubled
tool friction on a fresh bed leaves tool friction and "nothing missing" open; the run planned is
tool friction where it is plausible, not yet simulated and farthest from "nothing missing" over
the spread of one pass; it is simulated (3 tiny runs) and the answer refitted."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dempath_diagnose.adaptive import refine
from dempath_diagnose.decision.diagnosis import CaseGeometry, Diagnosis, diagnose
from dempath_diagnose.decision.measure import load_force, load_tracks
from dempath_diagnose.decision.verdict import CONFIDENT
from dempath_diagnose.library.cases import HiddenCase, make_case
from dempath_diagnose.library.simulator import load_scene
from dempath_diagnose.library.store import Library, extend_library, serial_executor
from dempath_diagnose.next_runs import plan_next
from dempath_diagnose.separation import GAP, REACH, candidate_runs, separate_pair

from .conftest import SCENE, SPEC

# Tool friction raised on a fresh bed: the scenario needs a case where tool friction and
# "nothing missing" are both left open. A bed under a tool is chaotic and the engine's kernels
# use fastmath, so which seed gives such a case moves with the processor's floating point and
# from day to day: x2 seed 13 gave 0.80 / 0.18 (tool friction / nothing) on 2026-11-28 and
# 0.34 / 0.65 a day later; x2 seed 17 0.63 / 0.36 on 2026-11-29 16:00 and 0.29 / 0.65 at 21:10
# (AMD EPYC), when x2 seed 23 gave 0.73 / 0.27, x2.25 seed 13 0.38 / 0.59, x2 seed 19 0.05 /
# 0.85, x2.25 seed 17 1.00 / 0.00. The test takes the first of these cases that the test
# library leaves inconclusive (each is one tiny run, cached) and fails if none does.
RIVAL_CASES = tuple(
    HiddenCase(f'tool_friction_rivals_x{scale}_seed{seed}',
               {'tool_friction.static_friction': 0.4 * scale,
                'tool_friction.dynamic_friction': 0.3 * scale},
               'tool_friction', ('parameter_off', 'inconclusive'), seed=seed)
    for scale, seed in ((2.0, 23), (2.0, 17), (2.25, 13), (2.0, 29)))


@pytest.mark.timeout(900)  # a guard, not a timing
def test_rivals_are_separated_where_they_differ_most(cache: Path, tiny_library: Library,
                                                     geometry: CaseGeometry,
                                                     tmp_path: Path) -> None:
    """The separating run lies where tool friction is plausible and interpolated, scores best,
    is simulated on the library's seeds and refitted; nothing wrong is named confidently."""
    scene = load_scene(SCENE)
    shutil.copytree(tiny_library.folder, tmp_path / 'library')
    library = Library.load(tmp_path / 'library')
    seen = []
    for case in RIVAL_CASES:
        markers, force = make_case(scene, case, cache / 'cases' / case.name,
                                   until_s=SPEC.duration_s, cache_dir=cache / 'packings')
        t, f = load_force(force)
        meas = replace(load_tracks(markers), force_times=t, force=f)
        first = diagnose(meas, library, geometry)
        dec = first.decision
        seen.append((case.name, dec.verdict))
        if dec.verdict == 'inconclusive':
            break
    assert dec.verdict == 'inconclusive', f'no rival case left open: {seen}'
    fits = {f.name: f for f in [dec.baseline, *dec.ranking]}
    tf, base = fits['tool_friction'], dec.baseline
    assert not tf.ruled_out and not base.ruled_out

    plan = plan_next(first, 3, set())
    (run,) = plan.runs
    assert run.why == 'separate' and run.candidate == 'tool_friction', run
    assert 'nothing missing' in run.reason
    scored = candidate_runs(first, tf, base)
    best = max(scored, key=lambda r: r.score)
    assert np.isclose(run.strength, best.strength)
    assert abs(run.strength - tf.strength) <= REACH * tf.strength_sd + 1e-9
    ce = next(c for c in first.emulator.candidates if c.candidate.name == 'tool_friction')
    span = float(ce.knots[-1] - ce.knots[0])
    assert np.min(np.abs(ce.knots - run.strength)) / span > 0.5 * GAP  # not yet simulated
    # the pair differs there by more than where it is already simulated at the scene's value
    at_scene = min(scored, key=lambda r: abs(r.strength - ce.candidate.current))
    assert best.z_max >= at_scene.z_max
    assert separate_pair(first, tf, base, {(run.candidate, round(run.strength, 9))}).best \
        != best  # a run made is never planned again

    def again(lib: Library) -> Diagnosis:
        return diagnose(meas, lib, geometry)

    def extend(lib: Library, additions: list[tuple[str, float]], seeds: int) -> Library:
        return extend_library(lib, scene, SPEC, additions, seeds, serial_executor,
                              cache / 'packings')

    final, grown, result = refine(first, library, again, extend, 3)
    (step,) = result.steps
    assert step.runs[0].why == 'separate' and result.used == 3
    assert len(grown.runs) == len(library.runs) + 3
    assert step.after != step.before  # the refit saw the new runs
    top = final.decision.ranking[0]
    named = final.decision.verdict in ('effect_missing', 'parameter_off')
    assert not (named and top.name != 'tool_friction' and top.probability > 0.5)
    assert not named or top.probability >= CONFIDENT
