"""Floors like for like: what the model itself gives on a figure, with the figure's own samples.

A figure (the headline error, Table 7's mean nRMSE) of a measurement against a model is judged
against its *floor*: the same figure when the model is the truth. The floor here is empirical and
computed exactly as the figure: each packing seed s of the model plays the measurement in turn
(per marker the k-th nearest particle to the marker's measured start, k = 0 .. ranks-1, at the
measured samples only, with the cameras' noise: :func:`~.samples.played_measurement`), scored
against the same model's cube candidates on the other seeds (a pool of as many seeds as the
figure's), the same cube and top N. A nominal band (chi-square) assumes a covariance; this one
assumes only that the model is right.

The band is a prediction interval for one more measurement, with the packing seed as the unit:
the floor figures of one seed (its particles taking turns as the marker) share a bed and a pool,
so twelve figures from three seeds are nowhere near twelve independent draws, and their 5-95 %
percentiles understate the floor's tails (issue 26: with them, two of 14 fitted wrong candidates
landed inside their floor bands). The floor figures are split into a between-seed and a
within-seed variance (one-way random effects); a new measurement's figure has the variance
sigma_b^2 (1 + 1/S) + sigma_w^2 (1 - 1/R) around their mean (S seeds, R ranks), and the band is
that mean +- t(0.95, df) of its square root, df by Welch-Satterthwaite (2 or 3 seeds give few
degrees of freedom: a wide band, as it should be). A figure above the band is *above* the floor
(one-sided 5 %).

A figure below its band is possible and is said so, with the reason that fits: a measured
marker that moves less than the model's particles (a shallow grain, noise lower than assumed),
or the figure's pool holding the measurement's own bed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dempath_diagnose.headline.samples import MarkerSamples, played_measurement
from dempath_diagnose.headline.score import headline_error
from dempath_diagnose.records import F64, Measurement, PassRecord

BAND_QUANTILE = 0.95  # the band's upper (and 1 - it, lower) one-sided prediction quantile
RANKS = 4  # particles per marker start that take turns as the marker (nearest first)

Figure = Callable[[Measurement, Sequence[PassRecord]], float]


@dataclass(frozen=True)
class FloorBand:
    """The floor of one figure.

    Attributes:
        low, high: The band (the seed-aware 90 % prediction interval, module docstring).
        median: Median of the samples.
        samples: Every floor figure (seed-major: seed 0's ranks, then seed 1's, ...).
        pool_seeds: Seeds per candidate pool (as the figure's).
        seeds: Packing seeds that played the measurement.
        df: Degrees of freedom of the band's t quantile.
    """

    low: float
    high: float
    median: float
    samples: tuple[float, ...]
    pool_seeds: int
    seeds: int = 0
    df: float = math.inf

    def place(self, value: float) -> str:
        """'above', 'in' or 'below' the band."""
        return 'above' if value > self.high else ('below' if value < self.low else 'in')

    def to_json(self, scale: float = 1.0) -> dict[str, Any]:
        """The band in ``scale`` units (1e3: mm)."""
        return {'low': self.low * scale, 'high': self.high * scale,
                'median': self.median * scale, 'n': len(self.samples),
                'pool_seeds': self.pool_seeds, 'seeds': self.seeds,
                'df': round(self.df, 2) if math.isfinite(self.df) else None,
                'samples': [round(v * scale, 6) for v in self.samples]}


def floor_band(samples: MarkerSamples, model: Sequence[PassRecord], figure: Figure,
               noise_m: float, pool_seeds: int, ranks: int = RANKS,
               rng_seed: int = 26) -> FloorBand:
    """The floor of ``figure`` for ``model`` (one run per packing seed), like for like.

    Args:
        samples: The figure's markers, starts and measured samples.
        model: The model's runs, one per packing seed.
        figure: figure(measurement, pool) -> value, the very function of the figure.
        noise_m: The cameras' noise per axis [m].
        pool_seeds: Seeds per pool of the figure; each seed plays the measurement against
            pools of this many of the other seeds.
        ranks: Particles per marker start that take turns as the marker.

    Raises:
        ValueError: Fewer than pool_seeds + 1 seeds.
    """
    if len(model) < pool_seeds + 1:
        msg = (f'floor_band: {len(model)} model seeds; a pool of {pool_seeds} needs '
               f'{pool_seeds + 1}')
        raise ValueError(msg)
    rng = np.random.default_rng(rng_seed)
    groups: list[list[float]] = []
    for s, rec in enumerate(model):
        others = [r for i, r in enumerate(model) if i != s][:pool_seeds]
        values = [figure(played_measurement(rec, samples, rank, noise_m, rng), others)
                  for rank in range(ranks)]
        groups.append([v for v in values if np.isfinite(v)])
    return band_of(groups, pool_seeds)


def band_of(groups: Sequence[Sequence[float]], pool_seeds: int) -> FloorBand:
    """The floor band of figures grouped by the seed that played the measurement.

    One-way random effects (seed, then rank within the seed): the band is the mean of the
    figures +- t(``BAND_QUANTILE``, df) times the predictive sd of one more seed's figure
    (module docstring). A single seed, or one figure per seed, falls back to the spread it has.

    Raises:
        ValueError: No finite figure.
    """
    from scipy import stats

    kept = [np.asarray(g, np.float64) for g in groups if len(g)]
    arr: F64 = np.concatenate(kept) if kept else np.zeros(0)
    if not len(arr):
        raise ValueError('floor_band: no finite floor figure')
    s, r = len(kept), float(np.mean([len(g) for g in kept]))
    means = np.array([g.mean() for g in kept])
    within = [np.var(g, ddof=1) for g in kept if len(g) > 1]
    msw = float(np.mean(within)) if within else 0.0
    msb = r * float(np.var(means, ddof=1)) if s > 1 else 0.0
    part_b = msb / r * (1.0 + 1.0 / s)
    part_w = msw * (1.0 - 1.0 / r)
    denom = (part_b ** 2 / (s - 1) if s > 1 else 0.0) + \
        (part_w ** 2 / (s * (r - 1)) if r > 1 else 0.0)
    df = (part_b + part_w) ** 2 / denom if denom > 0 else math.inf
    half = float(stats.t.ppf(BAND_QUANTILE, df) if math.isfinite(df)
                 else stats.norm.ppf(BAND_QUANTILE)) * math.sqrt(part_b + part_w)
    mean = float(arr.mean())
    low = max(mean - half, 0.0) if arr.min() >= 0.0 else mean - half  # figures >= 0 stay so
    return FloorBand(low, mean + half, float(np.median(arr)), tuple(arr.tolist()),
                     pool_seeds, s, float(df))


def headline_figure(cube: tuple[float, float, float]) -> Figure:
    """The headline error as a floor figure (one pool)."""
    return lambda meas, pool: headline_error(meas, [pool], cube).value


def below_reason(place: str, figure_name: str) -> str:
    """Why a figure may sit below its floor band ('' unless it does)."""
    if place != 'below':
        return ''
    return (f'{figure_name} lies below the floor band: the measured markers sit nearer the '
            "middle of the model's distribution than its own particles do (noise lower than "
            'assumed, or markers in a calmer spot of their cubes); it is not a better-than-true '
            'model')
