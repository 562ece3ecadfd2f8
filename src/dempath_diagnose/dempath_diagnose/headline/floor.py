"""Floors like for like: what the model itself gives on a figure, with the figure's own samples.

A figure (the headline error, Table 7's mean nRMSE) of a measurement against a model is judged
against its *floor*: the same figure when the model is the truth. The floor here is empirical and
computed exactly as the figure: each packing seed s of the model plays the measurement in turn
(per marker the k-th nearest particle to the marker's measured start, k = 0 .. ranks-1, at the
measured samples only, with the cameras' noise: :func:`~.samples.played_measurement`), scored
against the same model's cube candidates on the other seeds (a pool of as many seeds as the
figure's), the same cube and top N. The band is the 5-95 % range of those figures (ranks x
seeds of them; with the 3 seeds of a library and 4 ranks, 12). A nominal band (chi-square)
assumes a covariance; this one assumes only that the model is right.

A figure below its band is possible and is said so, with the reason that fits: a measured
marker that moves less than the model's particles (a shallow grain, noise lower than assumed),
or the figure's pool holding the measurement's own bed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dempath_diagnose.headline.samples import MarkerSamples, played_measurement
from dempath_diagnose.headline.score import headline_error
from dempath_diagnose.records import F64, Measurement, PassRecord

BAND = (5.0, 95.0)  # percentiles of the floor samples that make the band
RANKS = 4  # particles per marker start that take turns as the marker (nearest first)

Figure = Callable[[Measurement, Sequence[PassRecord]], float]


@dataclass(frozen=True)
class FloorBand:
    """The floor of one figure.

    Attributes:
        low, high: The band (5-95 % of the samples).
        median: Median of the samples.
        samples: Every floor figure (seed x rank).
        pool_seeds: Seeds per candidate pool (as the figure's).
    """

    low: float
    high: float
    median: float
    samples: tuple[float, ...]
    pool_seeds: int

    def place(self, value: float) -> str:
        """'above', 'in' or 'below' the band."""
        return 'above' if value > self.high else ('below' if value < self.low else 'in')

    def to_json(self, scale: float = 1.0) -> dict[str, Any]:
        """The band in ``scale`` units (1e3: mm)."""
        return {'low': self.low * scale, 'high': self.high * scale,
                'median': self.median * scale, 'n': len(self.samples),
                'pool_seeds': self.pool_seeds}


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
    values = []
    for s, rec in enumerate(model):
        others = [r for i, r in enumerate(model) if i != s][:pool_seeds]
        for rank in range(ranks):
            meas = played_measurement(rec, samples, rank, noise_m, rng)
            values.append(figure(meas, others))
    arr: F64 = np.array([v for v in values if np.isfinite(v)], np.float64)
    low, high = np.percentile(arr, BAND)
    return FloorBand(float(low), float(high), float(np.median(arr)), tuple(arr.tolist()),
                     pool_seeds)


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
