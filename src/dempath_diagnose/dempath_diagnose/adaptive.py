"""Spend a budget of simulations on an open diagnosis: run what would settle it, then refit.

``refine`` takes a diagnosis and, while it is open and the budget lasts, asks
:func:`~dempath_diagnose.next_runs.plan_next` what to simulate (past the library's edge,
or the contenders at their fitted strengths), has ``extend`` run those strengths on the
library's seeds (paired with its baseline runs; the runs go through the same executor as the
library, Dask or serial, and are stored in the library for the next case), diagnoses again with
the grown library and records each step: what was run and why, the verdict and every answer's
probability before and after. It stops when an answer is named, when nothing is missing, when the
budget is spent, or when the data cannot separate what remains (with the reason).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

from dempath_diagnose.decision.diagnosis import Diagnosis
from dempath_diagnose.library.store import Library
from dempath_diagnose.next_runs import PlannedRun, plan_next

# (library, [(candidate, strength)], seeds per strength) -> the library with those runs added
Extend = Callable[[Library, list[tuple[str, float]], int], Library]


def probabilities(d: Diagnosis) -> dict[str, float]:
    """Every answer's probability: ``nothing`` and each candidate."""
    out = {'nothing': round(float(d.decision.baseline.probability), 4)}
    out.update({f.name: round(float(f.probability), 4) for f in d.decision.ranking})
    return out


@dataclass(frozen=True)
class AdaptiveStep:
    """One round of extra simulations.

    Attributes:
        runs: The strengths run, each with why.
        simulations: Runs made (strengths x seeds).
        verdict_before, verdict_after: The verdict before and after the runs.
        before, after: Every answer's probability before and after.
        fitted_after: The top answer's fitted strength after the runs (NaN for nothing).
    """

    runs: tuple[PlannedRun, ...]
    simulations: int
    verdict_before: str
    verdict_after: str
    before: dict[str, float]
    after: dict[str, float]
    fitted_after: float = float('nan')


@dataclass(frozen=True)
class AdaptiveResult:
    """What the budget bought.

    Attributes:
        budget: Simulations allowed beyond the library.
        used: Simulations made.
        steps: The rounds, in order.
        stop: Why the loop stopped.
        verdict_before: The verdict on the library alone.
        before: Every answer's probability on the library alone.
        remaining_before: The answers not ruled out on the library alone.
        top_before: The most probable candidate on the library alone: effect, fitted
            strength, its sd and whether the fit lay at the range edge.
    """

    budget: int
    used: int
    steps: tuple[AdaptiveStep, ...] = field(default_factory=tuple)
    stop: str = ''
    verdict_before: str = ''
    before: dict[str, float] = field(default_factory=dict)
    remaining_before: tuple[str, ...] = ()
    top_before: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (diagnosis.json's ``adaptive``)."""
        return {'budget': self.budget, 'extra_simulations': self.used, 'stop': self.stop,
                'verdict_before': self.verdict_before, 'probabilities_before': self.before,
                'remaining_before': list(self.remaining_before),
                'top_before': self.top_before,
                'steps': [{**asdict(s), 'runs': [asdict(r) for r in s.runs]}
                          for s in self.steps]}


def refine(first: Diagnosis, library: Library, rediagnose: Callable[[Library], Diagnosis],
           extend: Extend, budget: int) -> tuple[Diagnosis, Library, AdaptiveResult]:
    """Spend up to ``budget`` simulations on ``first`` (see the module docstring).

    Args:
        first: The diagnosis on the library as it is.
        library: That library.
        rediagnose: The same diagnosis on another library (same measurement and settings).
        extend: Runs strengths on the library's seeds and returns the grown library.
        budget: Simulations allowed (0: nothing is run).

    Returns:
        The final diagnosis, the library it rests on and what was run.
    """
    seeds = len(library.seeds())
    d, used = first, 0
    steps: list[AdaptiveStep] = []
    done: set[tuple[str, float]] = set()
    stop = 'no simulation allowed (--budget 0)' if budget <= 0 else ''
    while not stop:
        plan = plan_next(d, budget - used, done)
        if not plan.runs:
            stop = plan.stop
            break
        per = min(seeds, budget - used)
        runs = list(plan.runs[:max(1, (budget - used) // per)])
        library = extend(library, [(r.candidate, r.strength) for r in runs], per)
        done.update((r.candidate, round(r.strength, 9)) for r in runs)
        after = rediagnose(library)
        used += per * len(runs)
        top = after.decision.ranking[0]
        steps.append(AdaptiveStep(tuple(runs), per * len(runs), d.decision.verdict,
                                  after.decision.verdict, probabilities(d),
                                  probabilities(after), float(top.strength)))
        d = after
    top = first.decision.ranking[0]
    result = AdaptiveResult(budget, used, tuple(steps), stop, first.decision.verdict,
                            probabilities(first), tuple(first.decision.remaining),
                            {'effect': top.name, 'strength': float(top.strength),
                             'sd': float(top.strength_sd),
                             'at_range_edge': bool(top.at_range_edge)})
    d.simulations = len(library.runs)
    return d, library, result


__all__ = ['AdaptiveResult', 'AdaptiveStep', 'Extend', 'probabilities', 'refine']
