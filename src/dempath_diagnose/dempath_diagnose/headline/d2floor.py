"""The d^2 floor like for like: what the model itself gives on the group-statistics distance.

The diagnosis and the recalibration judge a model by d^2, the Mahalanobis distance of the
measured group statistics from the model's prediction. Its nominal floor, chi^2_k, holds only if
the covariance is exactly right; the diagnosis' covariance carries a discrepancy allowance
(2 mm + 10 %) that dominates it, so a fitted model's d^2 lies far below chi^2_k (issue 26: d^2
5.3 below the "95 % band" 9.6-34.2 of k = 20). The floor here is computed as the figure is:
the model (the baseline, or a candidate at its fitted strength, from the library's paired runs:
:mod:`.ensemble`) on each packing seed in turn plays the measurement (the measured markers, at
the measured samples, with the cameras' noise: :func:`~.samples.played_measurement`), its
statistics are taken with the figure's own layout (markers, groups, windows; displacements from
the played marker's own start, as the figure's from the measured start), and d^2 is
computed against the emulator of the *other* seeds with the diagnosis' covariance; for a fitted
figure the candidate is fitted again on the 121-point strength grid, as the figure was. The band
is :func:`~.floor.band_of` (the seed as the unit).

Where the figure's emulator is built from every library seed (a user's measurement), its floor's
emulators have one seed fewer: the floor is then slightly wide (more emulator variance).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dempath_diagnose.decision.emulator import Allowance, build_emulator
from dempath_diagnose.decision.statistics import Layout, measured_statistics
from dempath_diagnose.decision.verdict import fit_baseline, fit_candidate
from dempath_diagnose.headline.ensemble import emulated_run
from dempath_diagnose.headline.floor import RANKS, FloorBand, band_of
from dempath_diagnose.headline.samples import MarkerSamples, played_measurement
from dempath_diagnose.library.store import Library


@dataclass(frozen=True)
class D2Setup:
    """What the d^2 figure was computed with.

    Attributes:
        layout: The figure's layout (markers, groups, windows).
        cube_m: Candidate cube (X, Y, Z) [m].
        allowance: Noise and discrepancy allowance of the diagnosis.
        ranks: Particles per marker start taking turns as the marker.
    """

    layout: Layout
    cube_m: tuple[float, float, float]
    allowance: Allowance = field(default_factory=Allowance)
    ranks: int = RANKS


def fold(library: Library, seed: int) -> Library:
    """The library without packing seed ``seed``."""
    keep = [r for r in library.runs if r.seed != seed]
    return Library(library.folder, library.candidates, keep,
                   {r.filename: library.records[r.filename] for r in keep}, library.region)


def d2_floor(library: Library, candidate: str, strength: float, samples: MarkerSamples,
             setup: D2Setup, fitted: bool, rng_seed: int = 26) -> FloorBand:
    """The floor band of d^2 for the model (``candidate`` at ``strength``; '' the baseline).

    Args:
        library: The library whose seeds play the measurement in turn.
        candidate, strength: The model.
        samples: The figure's markers, starts and measured samples (markers only).
        setup: The figure's layout, cube and allowance.
        fitted: The figure is a fitted d^2 (the candidate fitted again on each played
            measurement); else d^2 of the model as it is (the baseline's).

    Raises:
        ValueError: Fewer than three seeds (a fold needs two for the emulator's spread).
    """
    seeds = library.seeds()
    if len(seeds) < 3:
        raise ValueError(f'd2_floor: {len(seeds)} seeds; three or more needed')
    rng = np.random.default_rng(rng_seed)
    groups: list[list[float]] = []
    for s in seeds:
        truth = emulated_run(library, candidate, strength, s)
        emu = build_emulator(fold(library, s), setup.layout, setup.cube_m)
        cov = emu.fixed_cov(setup.allowance, setup.layout)
        cand = next((c for c in emu.candidates if c.candidate.name == candidate), None)
        values = []
        for rank in range(setup.ranks):
            meas = played_measurement(truth, samples, rank, setup.allowance.noise_m, rng)
            y, obs = observed_statistics(emu, meas, setup.layout)
            fit = (fit_candidate(emu, cand, y, obs, cov) if fitted and cand is not None
                   else fit_baseline(emu, y, obs, cov))
            values.append(float(fit.chi2))
        groups.append([v for v in values if np.isfinite(v)])
    return band_of(groups, len(seeds) - 1)


def observed_statistics(emu: Any, meas: Any, layout: Layout) -> tuple[Any, Any]:
    """The finite measured statistics and their mask over the emulator's (no force).

    A marker's displacements are taken from ``meas``'s own start (as the figure takes them from
    the measured start): the layout's groups, windows and cube counterparts stay the figure's.
    """
    y, _ = measured_statistics(meas, replace(layout, starts=meas.start))
    observed = ~emu.is_force()
    finite = np.isfinite(y)
    idx = np.flatnonzero(observed)
    observed[idx[~finite]] = False
    return y[finite], observed
