# ruff: noqa: N803, N806  (matrix notation of the references: K, R, P, X)
"""The paper's pixel-to-3D network (Technologies 2025, 13, 570, sec. 2.4 and Table 1), in torch.

Architecture as published: inputs (xs, ys, xf, yf), dense 2048-1024-512 with ReLU, linear 3
outputs (X, Y, Z). Two training recipes:

- the default (dempath's): inputs and targets standardised, no dropout, AdamW with a one-cycle
  learning rate over 10 epochs, batch 512, every training row used (no validation split); it
  reaches a fraction of a millimetre within a few minutes on two CPU cores
  (docs/reconstruction.md);
- ``PAPER_RECIPE`` (``MLPReconstructor.paper_recipe()``), as published: min-max scaling to 0..1,
  dropout 0.2 after each hidden layer, Adam at a constant rate, up to 60 epochs, validation split
  0.2, early stopping with patience 10 restoring the best weights. The paper used
  TensorFlow/Keras; the loss (MSE) and Adam's learning rate (Keras' default 1e-3) are not stated
  there and are assumed.

The class follows the scikit-learn estimator contract: hyperparameters only in ``__init__``,
``fit`` returns ``self``, learned attributes end in ``_``.
"""

from __future__ import annotations

import json
import logging
import pickle
import time
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from dempath_recon.errors import ModelFileError, NotFittedError, PixelInputError
from dempath_recon.methods.nets import (
    TrainSettings,
    build_mlp,
    predict_network,
    resolve_device,
    train_network,
)
from dempath_recon.methods.params import ParamsMixin
from dempath_recon.methods.scalers import make_scaler, scaler_from_dict

FloatArray = NDArray[np.float64]
logger = logging.getLogger(__name__)
MODEL_FORMAT = 'dempath-mlp-1'
# The published recipe (sec. 2.4, Table 1); everything else as in the defaults.
PAPER_RECIPE: dict[str, Any] = {'dropout': 0.2, 'epochs': 60, 'validation_fraction': 0.2,
                                'patience': 10, 'learning_rate': 1e-3, 'weight_decay': 0.0,
                                'optimizer': 'adam', 'schedule': 'constant',
                                'scaling': 'minmax'}
WEIGHT_DTYPES = {'float32': torch.float32, 'float16': torch.float16}


def check_pixels(pixels: FloatArray) -> FloatArray:
    """Pixels as float64 (n, 4) px = (xs, ys, xf, yf); raise PixelInputError otherwise."""
    arr = np.asarray(pixels, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 4:
        msg = f'pixels: expected shape (n, 4) = (xs, ys, xf, yf), got {arr.shape}'
        raise PixelInputError(msg)
    return arr


def read_model_file(path: str | Path, expected_format: str) -> dict[str, Any]:
    """Load a torch model file safely (``weights_only``) and check its format tag.

    Raises:
        ModelFileError: missing, unreadable, corrupt, or of another format.
    """
    path = Path(path)
    try:
        data = torch.load(path, map_location='cpu', weights_only=True)
    except FileNotFoundError as err:
        msg = f'{str(path)!r}: model file not found'
        raise ModelFileError(msg) from err
    except (OSError, RuntimeError, EOFError, pickle.UnpicklingError, zipfile.BadZipFile,
            ValueError) as err:
        msg = f'{str(path)!r}: not a readable model file ({type(err).__name__})'
        raise ModelFileError(msg) from err
    if not isinstance(data, dict) or data.get('format') != expected_format:
        found = data.get('format') if isinstance(data, dict) else type(data).__name__
        msg = f'{str(path)!r}: expected a {expected_format!r} model file, found {found!r}'
        raise ModelFileError(msg)
    return data


class MLPReconstructor(ParamsMixin):
    """The paper's multilayer perceptron mapping (xs, ys, xf, yf) px to (X, Y, Z) m.

    Args:
        hidden_sizes: widths of the hidden dense layers.
        dropout: dropout rate after each hidden layer (0: none).
        epochs: number of epochs (the maximum, when early stopping is on).
        batch_size: mini-batch size.
        validation_fraction: share of the training rows held out for early stopping (0: none,
            every row trains and the last weights are kept).
        patience: epochs without a better validation loss before stopping.
        learning_rate: constant step size, or the peak of the one-cycle schedule.
        weight_decay: L2 penalty (Adam) or decoupled weight decay (AdamW).
        optimizer: 'adamw' or 'adam'.
        schedule: 'onecycle' or 'constant'.
        scaling: 'standard' (zero mean, unit SD) or 'minmax' (0..1) for inputs and targets.
        random_state: seed of split, shuffling, initial weights and dropout (None: 0).
        device: 'auto' (CUDA when present, else CPU), 'cpu' or 'cuda'.
    """

    name = 'mlp'

    def __init__(self, hidden_sizes: tuple[int, ...] = (2048, 1024, 512), dropout: float = 0.0,
                 epochs: int = 10, batch_size: int = 512, validation_fraction: float = 0.0,
                 patience: int = 10, learning_rate: float = 2e-3, weight_decay: float = 1e-4,
                 optimizer: str = 'adamw', schedule: str = 'onecycle',
                 scaling: str = 'standard', random_state: int | None = None,
                 device: str = 'auto') -> None:
        self.hidden_sizes = tuple(hidden_sizes)
        self.dropout = dropout
        self.epochs = epochs
        self.batch_size = batch_size
        self.validation_fraction = validation_fraction
        self.patience = patience
        self.learning_rate = learning_rate
        self.weight_decay = weight_decay
        self.optimizer = optimizer
        self.schedule = schedule
        self.scaling = scaling
        self.random_state = random_state
        self.device = device

    @classmethod
    def paper_recipe(cls, **overrides: Any) -> MLPReconstructor:
        """An estimator with the published training recipe (``PAPER_RECIPE``), for Table 5."""
        return cls(**{**PAPER_RECIPE, **overrides})

    def _settings(self) -> TrainSettings:
        return TrainSettings(self.epochs, self.batch_size, self.validation_fraction,
                             self.patience, self.learning_rate, self.optimizer, self.schedule,
                             self.weight_decay)

    def fit(self, X: FloatArray, y: FloatArray, **_: Any) -> MLPReconstructor:
        """Train on calibration pixels X (n, 4) px and points y (n, 3) m; returns self."""
        X, y = check_pixels(X), np.asarray(y, dtype=np.float64)
        if y.shape != (len(X), 3):
            msg = f'y: expected shape ({len(X)}, 3) m, got {y.shape}'
            raise PixelInputError(msg)
        ok = np.isfinite(X).all(axis=1) & np.isfinite(y).all(axis=1)
        X, y = X[ok], y[ok]
        settings = self._settings()
        self.x_scaler_ = make_scaler(self.scaling).fit(X)
        self.y_scaler_ = make_scaler(self.scaling).fit(y)
        seed = 0 if self.random_state is None else int(self.random_state)
        torch.manual_seed(seed)
        self.device_ = resolve_device(self.device)
        self.model_ = build_mlp(4, self.hidden_sizes, 3, self.dropout)
        start, cpu_start = time.perf_counter(), time.process_time()
        log = train_network(self.model_, self.x_scaler_.transform(X),
                            self.y_scaler_.transform(y), settings, seed, self.device_)
        self.fit_time_s_ = time.perf_counter() - start
        self.fit_cpu_s_ = time.process_time() - cpu_start  # all threads; > wall when parallel
        self.loss_curve_ = log.loss_curve
        self.validation_curve_ = log.validation_curve
        self.epoch_time_s_ = log.epoch_s
        self.epoch_cpu_s_ = log.epoch_cpu_s
        self.epoch_load_ = log.epoch_load
        self.best_epoch_ = log.best_epoch
        self.n_iter_ = len(log.loss_curve)
        self.n_features_in_ = 4
        logger.info('MLP trained: %d epochs (best %d) in %.1f s', self.n_iter_,
                    self.best_epoch_, self.fit_time_s_)
        return self

    def predict(self, pixels: FloatArray) -> FloatArray:
        """Pixels (n, 4) px (xs, ys, xf, yf) -> world points (n, 3) m; NaN rows stay NaN."""
        if not hasattr(self, 'model_'):
            msg = 'MLPReconstructor: not fitted; call fit(X, y) or load(path) first'
            raise NotFittedError(msg)
        X = check_pixels(pixels)
        out = np.full((len(X), 3), np.nan)
        ok = np.isfinite(X).all(axis=1)
        if ok.any():
            scaled = predict_network(self.model_, self.x_scaler_.transform(X[ok]), self.device_)
            out[ok] = self.y_scaler_.inverse_transform(scaled)
        return out

    def save(self, path: str | Path, weights: str = 'float32') -> Path:
        """Write state_dict, scalers and config JSON to one torch file; returns the path.

        Args:
            path: the file to write.
            weights: 'float32', or 'float16' for half the size (the weights are rounded to half
                precision and computed in float32 again after ``load``).
        """
        if not hasattr(self, 'model_'):
            msg = 'MLPReconstructor: not fitted; nothing to save'
            raise NotFittedError(msg)
        if weights not in WEIGHT_DTYPES:
            msg = f'weights: expected one of {", ".join(WEIGHT_DTYPES)}, got {weights!r}'
            raise ValueError(msg)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        dtype = WEIGHT_DTYPES[weights]
        torch.save({'format': MODEL_FORMAT, 'config': json.dumps(self.get_params()),
                    'x_scaler': self.x_scaler_.to_dict(), 'y_scaler': self.y_scaler_.to_dict(),
                    'loss_curve': self.loss_curve_, 'validation_curve': self.validation_curve_,
                    'state_dict': {k: v.detach().cpu().to(dtype)
                                   for k, v in self.model_.state_dict().items()}},
                   path)
        return path

    @classmethod
    def load(cls, path: str | Path, device: str = 'auto') -> MLPReconstructor:
        """Read a file written by ``save``.

        Raises:
            ModelFileError: missing, corrupt or not an MLP model file.
        """
        data = read_model_file(path, MODEL_FORMAT)
        try:
            # files written before the recipe options were trained with the paper's recipe
            params = {**PAPER_RECIPE, **json.loads(data['config']), 'device': device}
            est = cls(**params)
            est.model_ = build_mlp(4, est.hidden_sizes, 3, est.dropout)
            state = {k: v.float() for k, v in data['state_dict'].items()}
            est.model_.load_state_dict(state)  # float16 files compute in float32
            est.x_scaler_ = scaler_from_dict(data['x_scaler'])
            est.y_scaler_ = scaler_from_dict(data['y_scaler'])
        except (KeyError, TypeError, ValueError, RuntimeError, AttributeError) as err:
            msg = f'{str(path)!r}: malformed MLP model file ({type(err).__name__}: {err})'
            raise ModelFileError(msg) from err
        est.device_ = resolve_device(device)
        est.model_.to(est.device_).eval()
        est.loss_curve_ = list(data.get('loss_curve', []))
        est.validation_curve_ = list(data.get('validation_curve', []))
        est.n_iter_ = len(est.loss_curve_)
        est.n_features_in_ = 4
        return est
