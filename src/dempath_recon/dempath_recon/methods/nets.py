# ruff: noqa: N803, N806  (matrix notation of the references: K, R, P, X)
"""Shared pieces of the learned reconstructors: the dense network and its training loop.

Their scalers are in ``methods.scalers``.

With ``optimizer='adam'``, ``schedule='constant'`` and a validation fraction, the training loop
reproduces what Keras' ``model.fit(..., validation_split=0.2,
callbacks=[EarlyStopping(patience=10, restore_best_weights=True)])`` does in the paper: mean
squared error on scaled targets, Adam, mini-batches reshuffled every epoch, the validation loss
measured after each epoch, and the best weights restored at the end. One difference is stated:
the validation rows are a seeded random 20% (Keras takes the last 20% of the array unshuffled).

``optimizer='adamw'`` with ``schedule='onecycle'`` is the budgeted recipe (decoupled weight decay,
Loshchilov & Hutter 2019; the one-cycle learning rate, Smith & Topin 2019, torch's
``OneCycleLR``): the learning rate warms up, peaks, and anneals to near zero over a fixed number
of epochs, so a short run ends at a converged point instead of wherever early stopping finds it.
With ``validation_fraction=0`` every row trains and the final weights are kept.
"""

from __future__ import annotations

import copy
import logging
import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import torch
from numpy.typing import NDArray
from torch import nn

from dempath_recon.errors import ReconstructionError

FloatArray = NDArray[np.float64]
logger = logging.getLogger(__name__)
SMALL_NET_PARAMS = 200_000  # below this, one CPU thread is faster than several (less overhead)


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


OPTIMIZERS = ('adam', 'adamw')
SCHEDULES = ('constant', 'onecycle')


@dataclass(frozen=True)
class TrainSettings:
    """Hyperparameters of :func:`train_network` (validated on construction).

    ``learning_rate`` is the constant rate, or the peak of the one-cycle schedule.
    ``validation_fraction`` 0 trains on every row and keeps the last weights (no early stop).
    """

    epochs: int
    batch_size: int
    validation_fraction: float
    patience: int
    learning_rate: float
    optimizer: str = 'adam'
    schedule: str = 'constant'
    weight_decay: float = 0.0

    def __post_init__(self) -> None:
        if self.epochs < 1 or self.batch_size < 1 or self.patience < 1:
            msg = f'epochs/batch_size/patience: must be >= 1, got {self}'
            raise ValueError(msg)
        if not 0.0 <= self.validation_fraction < 1.0:
            msg = f'validation_fraction: must be in [0, 1), got {self.validation_fraction}'
            raise ValueError(msg)
        if self.learning_rate <= 0 or self.weight_decay < 0:
            msg = (f'learning_rate / weight_decay: must be > 0 / >= 0, got '
                   f'{self.learning_rate} / {self.weight_decay}')
            raise ValueError(msg)
        if self.optimizer not in OPTIMIZERS or self.schedule not in SCHEDULES:
            msg = (f'optimizer / schedule: expected one of {OPTIMIZERS} / {SCHEDULES}, got '
                   f'{self.optimizer!r} / {self.schedule!r}')
            raise ValueError(msg)


@dataclass
class TrainLog:
    """What :func:`train_network` measured: per-epoch losses (scaled MSE), epochs, best, time.

    ``epoch_s`` is wall time, ``epoch_cpu_s`` the process's CPU time (all threads), and
    ``epoch_load`` the machine's 1-minute load average at each epoch's end: on a shared machine
    the wall time measures the other jobs as much as the training.
    """

    loss_curve: list[float] = field(default_factory=list)
    validation_curve: list[float] = field(default_factory=list)
    best_epoch: int = 0
    epoch_s: list[float] = field(default_factory=list)
    epoch_cpu_s: list[float] = field(default_factory=list)
    epoch_load: list[float] = field(default_factory=list)


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


def _epoch(model: nn.Module, opt: torch.optim.Optimizer, data: tuple[torch.Tensor, torch.Tensor],
           batch_size: int, gen: torch.Generator,
           sched: torch.optim.lr_scheduler.LRScheduler | None) -> float:
    """One pass over reshuffled mini-batches (a scheduler steps per batch); mean training loss."""
    X, y = data
    model.train()
    order = torch.randperm(len(X), generator=gen).to(X.device)
    total = 0.0
    for i in range(0, len(X), batch_size):
        idx = order[i:i + batch_size]
        opt.zero_grad(set_to_none=True)
        loss = ((model(X[idx]) - y[idx]) ** 2).mean()
        loss.backward()
        opt.step()
        if sched is not None:
            sched.step()
        total += float(loss.detach()) * len(idx)
    return total / len(X)


def _optimizer(model: nn.Module, settings: TrainSettings, n_train: int) -> tuple[
        torch.optim.Optimizer, torch.optim.lr_scheduler.LRScheduler | None]:
    """The optimizer and the per-batch learning-rate schedule (None: constant) of ``settings``."""
    kind = torch.optim.AdamW if settings.optimizer == 'adamw' else torch.optim.Adam
    opt = kind(model.parameters(), lr=settings.learning_rate, weight_decay=settings.weight_decay)
    if settings.schedule == 'constant':
        return opt, None
    steps = settings.epochs * -(-n_train // settings.batch_size)
    return opt, torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=settings.learning_rate,
                                                    total_steps=steps)


class _BestWeights:
    """Early stopping on the validation loss: the best epoch, its weights, epochs since."""

    def __init__(self, model: nn.Module, patience: int) -> None:
        self.patience, self.loss, self.epoch, self.wait = patience, float('inf'), 0, 0
        self.state = copy.deepcopy(model.state_dict())

    def stop_after(self, model: nn.Module, loss: float, epoch: int) -> bool:
        """Record epoch ``epoch`` (1-based) with validation ``loss``; True when to stop."""
        if loss < self.loss:
            self.loss, self.epoch, self.wait = loss, epoch, 0
            self.state = copy.deepcopy(model.state_dict())
            return False
        self.wait += 1
        return self.wait >= self.patience


def _train(model: nn.Module, X: FloatArray, y: FloatArray, settings: TrainSettings,
           seed: int, device: torch.device) -> TrainLog:
    """The loop of :func:`train_network`."""
    n_val = round(settings.validation_fraction * len(X))
    if (settings.validation_fraction > 0 and n_val < 1) or len(X) - n_val < 1:
        msg = f'training data: {len(X)} rows are too few for a validation split'
        raise ReconstructionError(msg)
    gen = torch.Generator().manual_seed(seed)
    torch.manual_seed(seed)
    perm = torch.randperm(len(X), generator=gen)
    Xt = torch.as_tensor(X, dtype=torch.float32)[perm].to(device)
    yt = torch.as_tensor(y, dtype=torch.float32)[perm].to(device)
    model.to(device)
    opt, sched = _optimizer(model, settings, len(X) - n_val)
    log, best = TrainLog(), _BestWeights(model, settings.patience) if n_val else None
    for epoch in range(1, settings.epochs + 1):
        start, cpu_start = time.perf_counter(), time.process_time()
        log.loss_curve.append(_epoch(model, opt, (Xt[n_val:], yt[n_val:]), settings.batch_size,
                                     gen, sched))
        if n_val:
            log.validation_curve.append(_mse(model, Xt[:n_val], yt[:n_val], settings.batch_size))
        log.epoch_s.append(time.perf_counter() - start)
        log.epoch_cpu_s.append(time.process_time() - cpu_start)
        log.epoch_load.append(os.getloadavg()[0])
        logger.info('epoch %d/%d: loss %.3g, validation %s, %.1f s', epoch, settings.epochs,
                    log.loss_curve[-1],
                    f'{log.validation_curve[-1]:.3g}' if n_val else 'none', log.epoch_s[-1])
        log.best_epoch = epoch  # without validation rows every epoch counts, the last is kept
        if best is not None and best.stop_after(model, log.validation_curve[-1], epoch):
            break
    if best is not None:
        model.load_state_dict(best.state)
        log.best_epoch = best.epoch
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
