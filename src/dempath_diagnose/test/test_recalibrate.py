"""The recalibration loop on a hand-made emulator and an analytic 'true' response with seed noise.

The emulator is linear in the strength; the true response is not (it bends), so the loop must
correct the emulator with its real evaluations. Each real evaluation draws its seeds' scatter from
the same seed covariance the objective assumes.
"""

from __future__ import annotations

import numpy as np
import pytest

from dempath_diagnose.emulator import CandidateEmulator, Emulator
from dempath_diagnose.errors import DiagnosisError
from dempath_diagnose.objective import Floor, Objective
from dempath_diagnose.recalibrate import check_strength, recalibrate
from dempath_diagnose.simulate import Candidate

K = 6
SD = 0.002  # seed spread of every statistic
SIG = np.array([0.02, 0.03, 0.01, 0.0, -0.01, 0.015])  # response at strength 1 (emulated)
SEEDS = 3


def true_response(x: float) -> np.ndarray:
    """The real model: the emulator's line bent by 15 % at strength 1."""
    return SIG * (x + 0.15 * x * x)


def setup(hidden: float) -> tuple[Objective, CandidateEmulator]:
    cand = Candidate('cohesion', 'effect', 'energy_density_j_m3', 'J/m^3', 0.0, 3.0, 0.0)
    ce = CandidateEmulator(cand, np.array([0.0, 1.0]), np.array([np.zeros(K), SIG]),
                           np.full((2, K), (0.3 * SD) ** 2), (0.0, 2.0))
    emu = Emulator([f's{i}' for i in range(K)], np.zeros(K), np.eye(K) * SD**2,
                   np.zeros((K, K)), [ce], np.zeros((3, K)), np.zeros((3, 1, 1, 3)),
                   np.zeros((1, 1, 3)))
    y = true_response(hidden) + np.random.default_rng(5).normal(0, SD, K)
    return Objective(emu, y, np.ones(K, bool), np.eye(K) * SD**2), ce


def evaluator(seed: int = 11, unstable_above: float = np.inf):
    rng = np.random.default_rng(seed)

    def evaluate(x: float) -> np.ndarray:
        if x > unstable_above:
            raise DiagnosisError(f'x = {x:.3f}: overlap blow-up')
        return true_response(x) + rng.normal(0, SD, (SEEDS, K))
    return evaluate


def test_hidden_effect_is_fitted_down_to_the_floor() -> None:
    obj, ce = setup(0.8)
    r = recalibrate(obj, ce, evaluator(), budget=18, seeds_per_eval=SEEDS)
    assert r.before > Floor.of(K).significant
    assert r.reduction >= 0.5
    assert r.changed and r.stop in ('floor', 'stalled')
    assert abs(r.strength - 0.8) <= max(2 * r.strength_sd, 0.1)
    assert r.steps[-1].simulations <= 18


def test_control_changes_nothing_and_says_so() -> None:
    obj, ce = setup(0.0)
    r = recalibrate(obj, ce, evaluator(), budget=18, seeds_per_eval=SEEDS)
    assert r.stop == 'nothing_to_fit' and not r.changed
    assert r.strength == ce.candidate.current and len(r.steps) == 1


def test_unstable_candidate_is_scored_failed_and_the_loop_goes_on() -> None:
    obj, ce = setup(0.8)
    r = recalibrate(obj, ce, evaluator(unstable_above=1.2), budget=30, seeds_per_eval=SEEDS,
                    start=1.5)
    failed = [s for s in r.steps if s.note.startswith('failed')]
    assert r.failures == len(failed) >= 1 and all(s.error == np.inf for s in failed)
    assert r.changed and r.after < r.before


def test_budget_zero_is_refused() -> None:
    obj, ce = setup(0.8)
    with pytest.raises(DiagnosisError, match='--budget 0'):
        recalibrate(obj, ce, evaluator(), budget=0, seeds_per_eval=SEEDS)


def test_interrupt_keeps_the_best_so_far() -> None:
    obj, ce = setup(0.8)
    inner = evaluator()
    calls = []

    def evaluate(x: float) -> np.ndarray:
        calls.append(x)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return inner(x)
    r = recalibrate(obj, ce, evaluate, budget=30, seeds_per_eval=SEEDS, start=0.3)
    assert r.stop == 'interrupted' and r.strength == calls[0] and r.after < r.before


def test_value_outside_physical_range_is_refused() -> None:
    _, ce = setup(0.8)
    with pytest.raises(DiagnosisError, match='outside the physical range'):
        check_strength(ce, 5.0)
