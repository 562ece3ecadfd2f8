"""A named answer is not named when it and a plausible rival both fit best at the edges of the
library's span.

The probabilities compare each candidate's likelihood over the strengths the library spans (its
prior: the span plus a quarter, within the physical range). A candidate that fits best at an end
of its span (``ModelFit.at_range_edge``) has a likelihood still rising towards strengths the
library never simulated, so its mass is truncated. For the named candidate alone that is
conservative: more span would only add to its mass, so it stays named (the report says its
strength sits at the range edge). But when a rival that is not ruled out also fits best at its
edge, the rival's mass is truncated too and past its edge it may overtake the named one: the
ranking is not decided by the data but by where the library stopped. On the tiny bench's rebuilt
library (2026-11-28) a doubled tool friction was named as restitution at p 0.87, restitution at
its upper edge and tool friction (the truth, 0.8 against a span ending at 0.69) at its own edge
with p 0.04; the rule makes that answer ``inconclusive`` and keeps strong cohesion and tool speed
x2 named (their rivals at an edge are ruled out). ``--budget N`` then runs the candidates past
their edges (:mod:`dempath_diagnose.next_runs`). The rule was written after that one wrong
answer was seen; it is checked on the tiny and ``tiny_rivals`` benches (docs/diagnosis.md). An
edge at a candidate's physical limit is not an edge of the library: nothing lies beyond it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from dempath_diagnose.decision.emulator import Emulator
from dempath_diagnose.decision.verdict import Decision, ModelFit

NAMED = ('effect_missing', 'parameter_off')


def _library_edge(fit: ModelFit, emu: Emulator) -> float | None:
    """The end of the library's span where ``fit`` peaks, or None (not at an edge, or at the
    candidate's physical limit)."""
    if not fit.at_range_edge:
        return None
    lo, hi = fit.strength_range
    high = fit.best >= 0.5 * (lo + hi)
    cand = emu.candidate_emulator(fit.name).candidate
    limit = cand.high if high else cand.low
    edge = hi if high else lo
    return None if np.isclose(edge, limit, rtol=1e-9, atol=0.0) else edge


def edge_decision(decision: Decision, emu: Emulator) -> Decision:
    """``decision`` made ``inconclusive`` when the named candidate and a rival not ruled out both
    fit best at the edges of the library's span (the candidates not ruled out remaining, the
    reason in the notes); else unchanged."""
    top = decision.ranking[0] if decision.ranking else None
    if decision.verdict not in NAMED or top is None:
        return decision
    edge = _library_edge(top, emu)
    if edge is None:
        return decision
    rivals = [f for f in decision.ranking[1:]
              if not f.ruled_out and _library_edge(f, emu) is not None]
    if not rivals:
        return decision
    lo, hi = top.strength_range
    named = ', '.join(f'{f.name} (p {f.probability:.2f})' for f in rivals)
    note = (f'{top.name} fits best at the edge of the library ({top.best:.4g} {top.unit}, '
            f'range {lo:.4g}-{hi:.4g}; p {top.probability:.2f}) and so do {named}, not ruled '
            'out: past the edges either may fit better, so none is named; '
            '`dempath diagnose --budget N` runs them past the edge')
    remaining = [f.name for f in (decision.baseline, *decision.ranking) if not f.ruled_out]
    return replace(decision, verdict='inconclusive', remaining=remaining,
                   notes=[*decision.notes, note])
