"""Scalers of the learned reconstructors' inputs and targets, and their model-file form.

``minmax`` maps each column's training range onto 0..1 (the paper's, scikit-learn's
``MinMaxScaler``); ``standard`` to zero mean and unit standard deviation (``StandardScaler``).
Plain numpy: a model file's scalers are read without torch.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass
class MinMaxScaler:
    """Per-column affine map of the training range onto 0..1 (scikit-learn's MinMaxScaler).

    Attributes:
        data_min: (d,) column minima of the training data.
        data_max: (d,) column maxima of the training data.
    """

    data_min: FloatArray = field(default_factory=lambda: np.zeros(0))
    data_max: FloatArray = field(default_factory=lambda: np.zeros(0))

    def fit(self, data: FloatArray) -> MinMaxScaler:
        """Learn the column ranges of ``data`` (n, d)."""
        self.data_min = np.nanmin(data, axis=0).astype(np.float64)
        self.data_max = np.nanmax(data, axis=0).astype(np.float64)
        return self

    @property
    def span(self) -> FloatArray:
        """(d,) column ranges; a constant column gets 1 so that it maps to 0."""
        span = self.data_max - self.data_min
        return np.where(span > 0, span, 1.0)

    def transform(self, data: FloatArray) -> FloatArray:
        """(n, d) -> (n, d) scaled to 0..1 over the training range."""
        return (np.asarray(data, np.float64) - self.data_min) / self.span

    def inverse_transform(self, scaled: FloatArray) -> FloatArray:
        """Inverse of ``transform``."""
        return np.asarray(scaled, np.float64) * self.span + self.data_min

    def to_dict(self) -> dict[str, Any]:
        """Plain lists for the model file."""
        return {'kind': 'minmax', 'data_min': self.data_min.tolist(),
                'data_max': self.data_max.tolist()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> MinMaxScaler:
        """Inverse of ``to_dict``."""
        return cls(np.asarray(data['data_min'], float), np.asarray(data['data_max'], float))


@dataclass
class StandardScaler:
    """Per-column map to zero mean and unit standard deviation (scikit-learn's StandardScaler).

    Attributes:
        mean: (d,) column means of the training data.
        scale: (d,) column standard deviations (1 for a constant column).
    """

    mean: FloatArray = field(default_factory=lambda: np.zeros(0))
    scale: FloatArray = field(default_factory=lambda: np.ones(0))

    def fit(self, data: FloatArray) -> StandardScaler:
        """Learn the column means and standard deviations of ``data`` (n, d)."""
        self.mean = np.nanmean(data, axis=0).astype(np.float64)
        std = np.nanstd(data, axis=0).astype(np.float64)
        self.scale = np.where(std > 0, std, 1.0)
        return self

    def transform(self, data: FloatArray) -> FloatArray:
        """(n, d) -> (n, d) standardised."""
        return (np.asarray(data, np.float64) - self.mean) / self.scale

    def inverse_transform(self, scaled: FloatArray) -> FloatArray:
        """Inverse of ``transform``."""
        return np.asarray(scaled, np.float64) * self.scale + self.mean

    def to_dict(self) -> dict[str, Any]:
        """Plain lists for the model file."""
        return {'kind': 'standard', 'mean': self.mean.tolist(), 'scale': self.scale.tolist()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> StandardScaler:
        """Inverse of ``to_dict``."""
        return cls(np.asarray(data['mean'], float), np.asarray(data['scale'], float))


Scaler = MinMaxScaler | StandardScaler
SCALINGS = ('minmax', 'standard')


def make_scaler(kind: str) -> Scaler:
    """A new scaler by name: 'minmax' (0..1, the paper's) or 'standard' (zero mean, unit SD)."""
    if kind == 'minmax':
        return MinMaxScaler()
    if kind == 'standard':
        return StandardScaler()
    msg = f'scaling: unknown {kind!r}; known: {", ".join(SCALINGS)}'
    raise ValueError(msg)


def scaler_from_dict(data: dict[str, Any]) -> Scaler:
    """A scaler from a model file's dict (files without 'kind' are min-max, format 1)."""
    if data.get('kind', 'minmax') == 'standard':
        return StandardScaler.from_dict(data)
    return MinMaxScaler.from_dict(data)
