"""Which candidates ``dempath recalibrate`` fits, what it refits beside them, and their budgets.

- ``--effect NAME[=START]`` (repeatable): those, in turn.
- Otherwise the diagnosis (this run's, or ``--diagnosis DIR/diagnosis.json``): its top candidate
  for ``effect_missing`` / ``parameter_off``; none for ``nothing_significant`` (the control
  path); for ``inconclusive`` every candidate not ruled out, in the diagnosis' order, each in
  turn (the report says which brings the error down).
- ``--also PARAM``: existing parameters of the scene (candidates of kind ``parameter``) refitted
  beside each candidate.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from pathlib import Path

from dempath_diagnose.decision.emulator import CandidateEmulator
from dempath_diagnose.decision.verdict import Decision
from dempath_diagnose.errors import DiagnosisError

MAX_TRIED = 3  # candidates tried in turn after an inconclusive diagnosis
Effect = tuple[str, float | None]  # a candidate to fit and its start value (None: the scene's)


def parse_effects(texts: Sequence[str]) -> tuple[Effect, ...]:
    """``['NAME', 'NAME=START', ...]`` (``--effect``) -> ((name, start or None), ...).

    Raises:
        DiagnosisError: A START that is not a number.
    """
    out: list[Effect] = []
    for text in texts:
        name, _, value = text.partition('=')
        try:
            out.append((name, float(value) if value else None))
        except ValueError as err:
            raise DiagnosisError(f'--effect {text!r}: START must be a number') from err
    return tuple(out)


def _known(effects: Sequence[Effect], known: Sequence[str]) -> list[Effect]:
    for name, _ in effects:
        if name not in known:
            raise DiagnosisError(f'--effect {name}: not a candidate of the signature library '
                                 f'(known: {", ".join(known)})')
    return list(effects)


def _from_file(path: Path) -> tuple[str, list[str], list[str]]:
    try:
        data = json.loads(path.read_text())
        return (data['verdict'], [r['effect'] for r in data['ranking']],
                list(data.get('remaining', [])))
    except (OSError, ValueError, KeyError, TypeError) as err:
        msg = f'{path}: not a readable diagnosis.json ({err})'
        raise DiagnosisError(msg) from err


def check_options(effects: Sequence[Effect], candidates: Sequence[str],
                  diagnosis: Path | None) -> None:
    """Refuse ``--effect`` names that are not among ``--candidates`` and an unreadable
    ``--diagnosis`` before anything is computed or written.

    Raises:
        DiagnosisError: One line naming the option and the problem.
    """
    _known(effects, candidates)
    if diagnosis is not None:
        _from_file(diagnosis)


def targets(effects: Sequence[Effect], diagnosis: Path | None, decision: Decision,
            known: Sequence[str]) -> list[Effect]:
    """The candidates to fit, with optional start values (see the module docstring):
    ``effects`` when given, else those of ``decision`` (or of the ``diagnosis`` file)."""
    if effects:
        return _known(effects, known)
    verdict, ranking, remaining = (decision.verdict, [f.name for f in decision.ranking],
                                   decision.remaining)
    if diagnosis is not None:
        verdict, ranking, remaining = _from_file(diagnosis)
    if verdict == 'nothing_significant':
        return []
    if verdict == 'inconclusive':
        names = [n for n in ranking if n in remaining and n in known][:MAX_TRIED] \
            or [n for n in ranking if n in known][:2]
        print(f'diagnosis: inconclusive ({", ".join(names)} remain); trying each in turn '
              '(choose one with --effect NAME)', file=sys.stderr)
        return [(n, None) for n in names]
    if ranking[0] not in known:
        raise DiagnosisError(f'diagnosis: {ranking[0]} is not a candidate of this library')
    return [(ranking[0], None)]


def named(effects: Sequence[Effect], diagnosis: Path | None, decision: Decision) -> bool:
    """Whether the candidates fitted were asked for (``--effect``) or named by the diagnosis
    (``effect_missing`` / ``parameter_off``): those are fitted even within the floor."""
    if effects:
        return True
    verdict = _from_file(diagnosis)[0] if diagnosis is not None else decision.verdict
    return verdict in ('effect_missing', 'parameter_off')


def also_candidates(names: Sequence[str], emus: dict[str, CandidateEmulator],
                    fitted: Sequence[str]) -> list[CandidateEmulator]:
    """The ``--also`` parameters: existing parameters of the scene, none of the fitted ones."""
    out = []
    for name in names:
        if name not in emus:
            raise DiagnosisError(f'--also {name}: not a candidate of the signature library '
                                 f'(known: {", ".join(emus)})')
        if emus[name].candidate.kind != 'parameter':
            raise DiagnosisError(f'--also {name}: the scene has this effect off; an existing '
                                 'parameter is refitted with --also, a new effect with --effect')
        if name in fitted:
            raise DiagnosisError(f'--also {name}: already fitted as the candidate')
        out.append(emus[name])
    return out


def budgets(total: int, per_eval: int, n: int) -> list[int]:
    """Simulations per candidate tried in turn: the total shared, at least one evaluation each
    (candidates beyond what the total allows are not tried)."""
    if n == 0:
        return []
    evals = total // per_eval
    if evals < 1:
        raise DiagnosisError(f'--budget {total}: at least {per_eval} simulations (one '
                             'evaluation over the packing seeds) are needed')
    share = [evals // n + (1 if k < evals % n else 0) for k in range(n)]
    return [s * per_eval for s in share if s > 0]
