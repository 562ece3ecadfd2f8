# ruff: noqa: N803, N806  (matrix notation of the references: K, R, P, X)
"""Shared pieces of the learned reconstructors: scalers, the dense network and its training loop.

The training loop reproduces what Keras' ``model.fit(..., validation_split=0.2,
callbacks=[EarlyStopping(patience=10, restore_best_weights=True)])`` does in the paper: mean
squared error on scaled targets, Adam, mini-batches reshuffled every epoch, the validation loss
measured after each epoch, and the best weights restored at the end. One difference is stated:
the validation rows are a seeded random 20% (Keras takes the last 20% of the array unshuffled).
"""

from __future__ import annotations

import copy
import logging
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray
from torch import nn

from dempath_recon.errors import ReconstructionError

FloatArray = NDArray[np.float64]
logger = logging.getLogger(__name__)
SMALL_NET_PARAMS = 200_000  # below this, one CPU thread is faster than several (less overhead)


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

    def to_dict(self) -> dict[str, list[float]]:
        """Plain lists for the model file."""
        return {'data_min': self.data_min.tolist(), 'data_max': self.data_max.tolist()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> MinMaxScaler:
        """Inverse of ``to_dict``."""
        return cls(np.asarray(data['data_min'], float), np.asarray(data['data_max'], float))


def resolve_device(device: str) -> torch.device:
    """'auto' -> CUDA when present, else CPU; any other string is passed to torch."""
    if device == 'auto':
        return torch.device('cuda' if torch.cuda.is_available() else 'cpu')
    return torch.device(device)


def build_mlp(n_in: int, hidden_sizes: tuple[int, ...], n_out: int,
              dropout: float) -> nn.Sequential:
    """Dense network: (Linear -> ReLU -> Dropout) per hidden size, then a linear output layer."""
    layers: list[nn.Module] = []
    width = n_in
    for size in hidden_sizes:
        layers += [nn.Linear(width, size), nn.ReLU()]
        if dropout > 0:
            layers.append(nn.Dropout(dropout))
        width = size
    layers.append(nn.Linear(width, n_out))
    return nn.Sequential(*layers)


@dataclass(frozen=True)
class TrainSettings:
    """Hyperparameters of :func:`train_network` (validated on construction)."""

    epochs: int
    batch_size: int
    validation_fraction: float
    patience: int
    learning_rate: float

    def __post_init__(self) -> None:
        if self.epochs < 1 or self.batch_size < 1 or self.patience < 1:
            msg = f'epochs/batch_size/patience: must be >= 1, got {self}'
            raise ValueError(msg)
        if not 0.0 < self.validation_fraction < 1.0:
            msg = f'validation_fraction: must be in (0, 1), got {self.validation_fraction}'
            raise ValueError(msg)
        if self.learning_rate <= 0:
            msg = f'learning_rate: must be > 0, got {self.learning_rate}'
            raise ValueError(msg)


@dataclass
class TrainLog:
    """What :func:`train_network` measured: per-epoch losses (scaled MSE), epochs, best, time."""

    loss_curve: list[float] = field(default_factory=list)
    validation_curve: list[float] = field(default_factory=list)
    best_epoch: int = 0
    epoch_s: list[float] = field(default_factory=list)


def _mse(model: nn.Module, X: torch.Tensor, y: torch.Tensor, batch: int) -> float:
    model.eval()
    total = 0.0
    with torch.no_grad():
        for i in range(0, len(X), batch * 8):
            total += float(((model(X[i:i + batch * 8]) - y[i:i + batch * 8]) ** 2).sum())
    return total / (len(X) * y.shape[1])


@contextmanager
def cpu_threads_for(model: nn.Module) -> Iterator[None]:
    """Run small networks on one CPU thread (restored afterwards): thread hand-offs cost more
    than the arithmetic, much more on a loaded machine."""
    n_params = sum(p.numel() for p in model.parameters())
    before = torch.get_num_threads()
    if n_params < SMALL_NET_PARAMS:
        torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def train_network(model: nn.Module, X: FloatArray, y: FloatArray, settings: TrainSettings,
                  seed: int, device: torch.device) -> TrainLog:
    """Train with Adam on MSE, early stopping on validation loss, best weights restored.

    Args:
        model: the network (moved to ``device``).
        X: (n, d_in) scaled inputs.
        y: (n, d_out) scaled targets.
        settings: epochs, batch size, validation fraction, patience, learning rate.
        seed: seed of the split, the shuffling and the dropout masks.
        device: torch device.

    Returns:
        The :class:`TrainLog`; ``model`` holds the best weights afterwards.
    """
    with cpu_threads_for(model):
        return _train(model, X, y, settings, seed, device)


def _epoch(model: nn.Module, opt: torch.optim.Optimizer, X: torch.Tensor, y: torch.Tensor,
           batch_size: int, gen: torch.Generator) -> float:
    """One pass over reshuffled mini-batches; returns the mean training loss."""
    model.train()
    order = torch.randperm(len(X), generator=gen).to(X.device)
    total = 0.0
    for i in range(0, len(X), batch_size):
        idx = order[i:i + batch_size]
        opt.zero_grad()
        loss = ((model(X[idx]) - y[idx]) ** 2).mean()
        loss.backward()
        opt.step()
        total += float(loss.detach()) * len(idx)
    return total / len(X)


def _train(model: nn.Module, X: FloatArray, y: FloatArray, settings: TrainSettings,
           seed: int, device: torch.device) -> TrainLog:
    """The loop of :func:`train_network`."""
    n_val = round(settings.validation_fraction * len(X))
    if n_val < 1 or len(X) - n_val < 1:
        msg = f'training data: {len(X)} rows are too few for a validation split'
        raise ReconstructionError(msg)
    gen = torch.Generator().manual_seed(seed)
    torch.manual_seed(seed)
    perm = torch.randperm(len(X), generator=gen)
    Xt = torch.as_tensor(X, dtype=torch.float32)[perm].to(device)
    yt = torch.as_tensor(y, dtype=torch.float32)[perm].to(device)
    model.to(device)
    opt = torch.optim.Adam(model.parameters(), lr=settings.learning_rate)
    log, best, best_state, wait = TrainLog(), float('inf'), copy.deepcopy(model.state_dict()), 0
    for epoch in range(settings.epochs):
        start = time.perf_counter()
        log.loss_curve.append(_epoch(model, opt, Xt[n_val:], yt[n_val:], settings.batch_size,
                                     gen))
        log.validation_curve.append(_mse(model, Xt[:n_val], yt[:n_val], settings.batch_size))
        log.epoch_s.append(time.perf_counter() - start)
        logger.info('epoch %d: loss %.3g, validation %.3g, %.1f s', epoch + 1,
                    log.loss_curve[-1], log.validation_curve[-1], log.epoch_s[-1])
        if log.validation_curve[-1] < best:
            best, wait, log.best_epoch = log.validation_curve[-1], 0, epoch + 1
            best_state = copy.deepcopy(model.state_dict())
        else:
            wait += 1
            if wait >= settings.patience:
                break
    model.load_state_dict(best_state)
    model.eval()
    return log


def predict_network(model: nn.Module, X: FloatArray, device: torch.device,
                    batch: int = 65536) -> FloatArray:
    """Evaluate ``model`` on (n, d_in) scaled inputs in batches; (n, d_out) float64."""
    model.eval()
    out = []
    with torch.no_grad(), cpu_threads_for(model):
        for i in range(0, len(X), batch):
            xb = torch.as_tensor(X[i:i + batch], dtype=torch.float32, device=device)
            out.append(model(xb).cpu().numpy().astype(np.float64))
    return np.concatenate(out) if out else np.zeros((0, 0))
