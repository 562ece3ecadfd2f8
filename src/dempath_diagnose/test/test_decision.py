"""The decision on a hand-made emulator: each verdict path, probabilities and separators."""

from __future__ import annotations

import numpy as np

from dempath_diagnose.decision.emulator import CandidateEmulator, Emulator
from dempath_diagnose.decision.verdict import decide, sigma_of
from dempath_diagnose.library.simulator import Candidate

NAMES = ['right:lateral_out:w0', 'right:lateral_out:w1', 'axis:forward:w0', 'axis:forward:w1',
         'force:draft:w0', 'force:draft:w1']
SD = 0.002  # seed spread of every statistic [m] (and [N] for the draft)


def make_emulator(signatures: dict[str, list[float]]) -> Emulator:
    """Baseline 0 with sd SD; each candidate moves the statistics linearly from 0 at 0 to its
    signature at strength 1 (prior 0..1.25)."""
    k = len(NAMES)
    cands = []
    for name, sig in signatures.items():
        cand = Candidate(name, 'effect', 'p', '1', 0.0, 2.0, 0.0)
        cands.append(CandidateEmulator(cand, np.array([0.0, 1.0]),
                                       np.array([np.zeros(k), np.array(sig)]),
                                       np.full((2, k), (0.2 * SD) ** 2), (0.0, 1.25)))
    return Emulator(NAMES, np.zeros(k), np.eye(k) * SD**2, np.zeros((k, k)), cands,
                    np.zeros((3, k)), np.zeros((3, 1, 1, 3)), np.zeros((1, 1, 3)))


def test_baseline_data_gives_nothing_significant() -> None:
    """Data at the baseline mean: nothing_significant, the baseline most probable."""
    emu = make_emulator({'a': [0.02, 0.03, 0, 0, 0, 0], 'b': [0, 0, 0.02, 0.03, 0, 0]})
    d = decide(emu, np.zeros(6), np.ones(6, bool), np.eye(6) * SD**2)
    assert d.verdict == 'nothing_significant'
    assert d.baseline.probability > max(f.probability for f in d.ranking)
    assert not d.baseline.ruled_out


def test_strong_signature_is_named_with_its_strength() -> None:
    """Data on candidate a's signature at strength 0.6: effect_missing a, strength ~0.6."""
    sig = np.array([0.02, 0.03, 0, 0, 0, 0])
    emu = make_emulator({'a': list(sig), 'b': [0, 0, 0.02, 0.03, 0, 0]})
    d = decide(emu, 0.6 * sig, np.ones(6, bool), np.eye(6) * SD**2)
    assert d.verdict == 'effect_missing'
    top = d.ranking[0]
    assert top.name == 'a' and top.probability >= 0.8
    assert abs(top.strength - 0.6) < 2 * top.strength_sd + 0.05
    assert d.baseline.ruled_out
    assert top.explained_fraction > 0.8


def test_twins_on_markers_are_inconclusive_and_the_force_separates_them() -> None:
    """Two candidates with the same marker signature and different draft, force unmeasured:
    inconclusive with both named and a draft-force measurement as what would separate them."""
    emu = make_emulator({'a': [0.02, 0.03, 0, 0, 0.01, 0.02],
                         'b': [0.02, 0.03, 0, 0, -0.01, -0.02]})
    observed = np.array([True, True, True, True, False, False])
    y = np.array([0.02, 0.03, 0.0, 0.0])
    d = decide(emu, y, observed, np.eye(6) * SD**2)
    assert d.verdict == 'inconclusive'
    assert {'a', 'b'} <= set(d.remaining)
    assert 'baseline' not in d.remaining
    assert any('draft-force measurement' in s for s in d.separators), d.separators
    assert all(f.probability < 0.8 for f in d.ranking)


def test_with_the_force_the_twins_separate() -> None:
    """The same twins with the draft measured: the right one is named."""
    sig = [0.02, 0.03, 0, 0, 0.01, 0.02]
    emu = make_emulator({'a': sig, 'b': [0.02, 0.03, 0, 0, -0.01, -0.02]})
    d = decide(emu, np.array(sig), np.ones(6, bool), np.eye(6) * SD**2)
    assert d.verdict == 'effect_missing' and d.ranking[0].name == 'a'


def test_data_no_model_explains_is_inconclusive() -> None:
    """A discrepancy no candidate produces: every model ruled out, inconclusive, not named."""
    emu = make_emulator({'a': [0.02, 0.03, 0, 0, 0, 0], 'b': [0, 0, 0.02, 0.03, 0, 0]})
    y = np.array([-0.03, 0.03, -0.03, 0.03, -0.03, 0.03])
    d = decide(emu, y, np.ones(6, bool), np.eye(6) * SD**2)
    assert d.verdict == 'inconclusive'
    assert d.baseline.ruled_out and all(f.ruled_out for f in d.ranking)


def test_sigma_of_matches_the_gaussian_in_one_dimension() -> None:
    """For k = 1 the implausibility is |r| / sd."""
    assert abs(sigma_of(9.0, 1) - 3.0) < 1e-6
    assert abs(sigma_of(1.0, 1) - 1.0) < 1e-6


def test_candidates_that_contain_the_baseline_do_not_dilute_it() -> None:
    """Seven candidates, none able to move the statistics beyond one sd at any strength, and data
    at the baseline: 'nothing missing' keeps the probability (not 1/8 of it); a strong candidate
    beside them still loses it when its signature is in the data."""
    weak = {f'w{i}': [0.0015 * (i % 2), 0.0015 * (1 - i % 2), 0, 0, 0, 0] for i in range(7)}
    emu = make_emulator(weak)
    d = decide(emu, np.zeros(6), np.ones(6, bool), np.eye(6) * SD**2)
    assert d.verdict == 'nothing_significant'
    assert d.baseline.probability > 0.95, d.baseline.probability
    assert all(f.probability < 0.01 for f in d.ranking)
    sig = [0, 0, 0.02, 0.03, 0, 0]
    emu = make_emulator({**weak, 'strong': sig})
    d = decide(emu, np.array(sig), np.ones(6, bool), np.eye(6) * SD**2)
    assert d.verdict == 'effect_missing' and d.ranking[0].name == 'strong'
    assert d.baseline.probability < 0.01


def test_probabilities_of_the_answers_sum_to_one() -> None:
    """'Nothing missing' plus every candidate's distinguishable part: one distribution."""
    emu = make_emulator({'a': [0.02, 0.03, 0, 0, 0, 0], 'b': [0, 0, 0.004, 0.006, 0, 0]})
    d = decide(emu, np.array([0.003, 0.004, 0.001, 0.0, 0.0, 0.0]), np.ones(6, bool),
               np.eye(6) * SD**2)
    total = d.baseline.probability + sum(f.probability for f in d.ranking)
    assert abs(total - 1.0) < 1e-9


def test_a_strength_beyond_the_range_is_flagged_at_its_edge() -> None:
    """Data on a's signature at strength 2 (the range ends at 1.25): the fit sits at the edge
    and says so; a strength inside the range does not."""
    sig = np.array([0.02, 0.03, 0, 0, 0, 0])
    emu = make_emulator({'a': list(sig), 'b': [0, 0, 0.02, 0.03, 0, 0]})
    beyond = decide(emu, 2.0 * sig, np.ones(6, bool), np.eye(6) * SD**2).ranking[0]
    inside = decide(emu, 0.6 * sig, np.ones(6, bool), np.eye(6) * SD**2).ranking[0]
    assert beyond.name == 'a' and beyond.at_range_edge
    assert beyond.strength_range == (0.0, 1.25) and beyond.best == 1.25
    assert inside.name == 'a' and not inside.at_range_edge


def test_a_candidate_that_scatters_more_is_judged_by_its_own_scatter() -> None:
    """Candidate a's grains scatter 9x the baseline's variance at strength 1 (a cohesive bed):
    data drawn there, 2.5 of the baseline's sd off a's mean on every statistic, rule a out
    under the baseline's scatter and name it under its own (issue 32: strong cohesion ruled out
    at its own fit)."""
    from dataclasses import replace

    sig = np.array([0.02, 0.03, 0.02, 0.03, 0.02, 0.03])
    emu = make_emulator({'a': list(sig), 'b': [0, 0, 0.02, 0.03, 0, 0]})
    k = len(NAMES)
    wide = np.eye(k) * 9 * SD**2
    own = [replace(c, sampling=np.array([np.zeros((k, k)), wide if c.candidate.name == 'a'
                                         else np.zeros((k, k))])) for c in emu.candidates]
    y = sig + 2.5 * SD * np.array([1, -1, 1, -1, 1, -1])
    pooled = decide(emu, y, np.ones(k, bool), np.eye(k) * SD**2)
    fair = decide(replace(emu, candidates=own, base_sampling=np.zeros((k, k))), y,
                  np.ones(k, bool), np.eye(k) * SD**2)
    assert pooled.ranking[0].name == 'a' and pooled.ranking[0].ruled_out
    assert fair.verdict == 'effect_missing' and fair.ranking[0].name == 'a'
    assert not fair.ranking[0].ruled_out and fair.ranking[0].probability >= 0.8


def test_spread_levels_find_the_group_that_varies_more() -> None:
    """Three seeds per group, 40 statistics: a group drawn with 6x the variance gets a level
    near 6 times the others'; with the pool weighted infinitely every level is 1; a group of
    one run keeps the pool's."""
    from dempath_diagnose.decision.emulator import spread_levels

    rng = np.random.default_rng(3)
    scale = rng.uniform(0.5, 2.0, 40)  # each statistic its own unit

    def group(var: float, n: int = 3) -> np.ndarray:
        x = rng.normal(size=(n, 40)) * scale * np.sqrt(var)
        return x - x.mean(0)

    groups = [group(1.0) for _ in range(6)] + [group(6.0), group(1.0, 1)]
    raw = spread_levels(groups, prior_dof=0.0)
    assert 3.5 < raw[6] / np.median(raw[:6]) < 10.0
    assert np.all(np.abs(np.log(raw[:6])) < np.log(2.0))
    assert raw[7] == 1.0
    assert np.allclose(spread_levels(groups, prior_dof=float('inf')), 1.0)
    shrunk = spread_levels(groups, prior_dof=2.0)
    assert 1.0 < shrunk[6] / np.median(shrunk[:6]) < raw[6] / np.median(raw[:6])
