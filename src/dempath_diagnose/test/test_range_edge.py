"""The range-edge rule on a hand-made emulator: a named answer whose fit and a plausible rival's
fit both sit at the edges of the library's span is not named; alone at its edge it stays named;
an edge at the physical limit is no edge."""

from __future__ import annotations

import numpy as np

from dempath_diagnose.decision.emulator import CandidateEmulator, Emulator
from dempath_diagnose.decision.range_edge import edge_decision
from dempath_diagnose.decision.verdict import Decision, decide
from dempath_diagnose.library.simulator import Candidate

from .test_decision import NAMES, SD

SIG_A = np.array([0.004, 0.006, 0.002, 0.003, 0.004, 0.006])  # at strength 1 (library's end)


def emulator(signatures: dict[str, np.ndarray], high: float = 2.0) -> Emulator:
    """Baseline 0; each candidate linear from 0 to its signature at 1, simulated on 0..1, prior
    0..1.25 (the span plus a quarter), physical range 0..``high``."""
    k = len(NAMES)
    cands = [CandidateEmulator(Candidate(n, 'effect', 'p', '1', 0.0, high, 0.0),
                               np.array([0.0, 1.0]), np.array([np.zeros(k), sig]),
                               np.full((2, k), (0.2 * SD) ** 2), (0.0, min(1.25, high)))
             for n, sig in signatures.items()]
    return Emulator(NAMES, np.zeros(k), np.eye(k) * SD**2, np.zeros((k, k)), cands,
                    np.zeros((3, k)), np.zeros((3, 1, 1, 3)), np.zeros((1, 1, 3)))


def decided(emu: Emulator, y: np.ndarray) -> tuple[Decision, Decision]:
    """(the decision as the probabilities give it, the same with the range-edge rule)."""
    d = decide(emu, y, np.ones(len(NAMES), bool), np.eye(len(NAMES)) * SD**2)
    return d, edge_decision(d, emu)


def test_named_answer_and_a_plausible_rival_at_their_edges_is_not_named() -> None:
    """The truth lies past both spans (a at 1.8 of 1.25) and b's signature is a's with a
    slightly different draft: both fit at their upper edges, b not ruled out. The
    probabilities name a; the rule leaves it inconclusive, both remaining, the reason said."""
    sig_b = SIG_A * np.array([1.0, 1.0, 1.0, 1.0, 0.8, 0.8])
    emu = emulator({'a': SIG_A, 'b': sig_b})
    before, after = decided(emu, 1.8 * SIG_A)
    a, b = (next(f for f in before.ranking if f.name == n) for n in 'ab')
    assert a.at_range_edge and b.at_range_edge and not b.ruled_out
    assert before.verdict == 'effect_missing' and before.ranking[0].name == 'a'
    assert after.verdict == 'inconclusive'
    assert {'a', 'b'} <= set(after.remaining)
    assert any('edge of the library' in n and 'budget' in n for n in after.notes)
    assert after.ranking == before.ranking  # the probabilities are not touched


def test_named_answer_alone_at_its_edge_stays_named() -> None:
    """Past a's span with b's signature elsewhere (b ruled out): a stays named."""
    emu = emulator({'a': SIG_A, 'b': -SIG_A[::-1]})
    before, after = decided(emu, 1.8 * SIG_A)
    assert before.ranking[0].at_range_edge and before.verdict == 'effect_missing'
    assert after == before


def test_edge_at_the_physical_limit_is_no_edge() -> None:
    """Both spans end at the physical limit (1.25): nothing lies beyond, a stays named."""
    sig_b = SIG_A * np.array([1.0, 1.0, 1.0, 1.0, 0.8, 0.8])
    emu = emulator({'a': SIG_A, 'b': sig_b}, high=1.25)
    before, after = decided(emu, 1.8 * SIG_A)
    assert before.ranking[0].at_range_edge and before.verdict == 'effect_missing'
    assert after == before
