# ruff: noqa: N803, N806  (matrix notation of the references: K, R, P, X)
"""Triangulation plus a small network that learns only what triangulation gets wrong.

Triangulation from a calibration is exact up to noise when the camera model is right; what is
left (calibration bias, lens effects the 5-coefficient model misses, a slightly moved camera) is a
smooth field over the working volume. A small dense network learns that residual
``xyz_true - xyz_dlt`` from the calibration point set, inputs the min-max scaled pixels and the
scaled triangulated point. It trains in seconds where the paper's network takes tens of minutes,
and it can never be worse than triangulation by more than what it learns from noise, because the
residual target starts at zero (the output layer is zero-initialised) and early stopping on the
validation loss keeps the best weights.
"""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from dempath_recon.errors import ModelFileError, NotFittedError
from dempath_recon.methods.mlp import check_pixels, read_model_file
from dempath_recon.methods.nets import (
    TrainSettings,
    build_mlp,
    predict_network,
    resolve_device,
    train_network,
)
from dempath_recon.methods.params import ParamsMixin
from dempath_recon.methods.scalers import MinMaxScaler
from dempath_recon.methods.triangulate import DLTTriangulator

FloatArray = NDArray[np.float64]
logger = logging.getLogger(__name__)
MODEL_FORMAT = 'dempath-residual-1'


class ResidualReconstructor(ParamsMixin):
    """DLT triangulation corrected by a small network trained on its residual.

    Args:
        hidden_sizes: widths of the hidden layers of the residual network.
        epochs: maximum epochs.
        batch_size: mini-batch size.
        validation_fraction: share of training rows for early stopping.
        patience: epochs without improvement before stopping.
        learning_rate: Adam step size.
        refine: Gauss-Newton refinement in the underlying triangulation.
        random_state: seed (None: 0).
        device: 'auto', 'cpu' or 'cuda'.
    """

    name = 'dlt_residual'

    def __init__(self, hidden_sizes: tuple[int, ...] = (64, 64), epochs: int = 40,
                 batch_size: int = 256, validation_fraction: float = 0.2, patience: int = 6,
                 learning_rate: float = 1e-3, refine: bool = False,
                 random_state: int | None = None, device: str = 'auto') -> None:
        self.hidden_sizes = tuple(hidden_sizes)
        self.epochs = epochs
        self.batch_size = batch_size
        self.validation_fraction = validation_fraction
        self.patience = patience
        self.learning_rate = learning_rate
        self.refine = refine
        self.random_state = random_state
        self.device = device

    def _features(self, X: FloatArray, base_xyz: FloatArray) -> FloatArray:
        return np.hstack([self.x_scaler_.transform(X), self.p_scaler_.transform(base_xyz)])

    def fit(self, X: FloatArray, y: FloatArray, *,
            calibration: Any = None) -> ResidualReconstructor:
        """Fit the triangulation (calibration given, or resected from X, y), then the residual.

        Args:
            X: (n, 4) calibration pixels [px].
            y: (n, 3) calibration points [m].
            calibration: ``StereoCalibration`` or cameras; None resects them from X, y.

        Returns:
            self, with ``base_``, ``model_``, ``loss_curve_``, ``n_iter_`` set.
        """
        X, y = check_pixels(X), np.asarray(y, dtype=np.float64)
        self.base_ = DLTTriangulator(refine=self.refine).fit(X, y, calibration=calibration)
        base_xyz = self.base_.predict(X)
        ok = np.isfinite(base_xyz).all(axis=1) & np.isfinite(y).all(axis=1)
        X, y, base_xyz = X[ok], y[ok], base_xyz[ok]
        self.x_scaler_ = MinMaxScaler().fit(X)
        self.p_scaler_ = MinMaxScaler().fit(base_xyz)
        residual = y - base_xyz
        self.r_scale_ = float(max(residual.std(), 1e-9))  # m per network output unit
        seed = 0 if self.random_state is None else int(self.random_state)
        torch.manual_seed(seed)
        self.device_ = resolve_device(self.device)
        self.model_ = build_mlp(7, self.hidden_sizes, 3, 0.0)
        last = self.model_[-1]
        assert isinstance(last, torch.nn.Linear)
        torch.nn.init.zeros_(last.weight)
        torch.nn.init.zeros_(last.bias)
        start = time.perf_counter()
        settings = TrainSettings(self.epochs, self.batch_size, self.validation_fraction,
                                 self.patience, self.learning_rate)
        log = train_network(self.model_, self._features(X, base_xyz), residual / self.r_scale_,
                            settings, seed, self.device_)
        self.fit_time_s_ = time.perf_counter() - start
        self.loss_curve_, self.validation_curve_ = log.loss_curve, log.validation_curve
        self.n_iter_, self.n_features_in_ = len(log.loss_curve), 4
        return self

    def predict(self, pixels: FloatArray) -> FloatArray:
        """Pixels (n, 4) px -> world points (n, 3) m; NaN where triangulation gives NaN."""
        if not hasattr(self, 'model_'):
            msg = 'ResidualReconstructor: not fitted; call fit(X, y) or load(path) first'
            raise NotFittedError(msg)
        X = check_pixels(pixels)
        xyz = self.base_.predict(X)
        ok = np.isfinite(xyz).all(axis=1) & np.isfinite(X).all(axis=1)
        if ok.any():
            corr = predict_network(self.model_, self._features(X[ok], xyz[ok]), self.device_)
            xyz[ok] += corr * self.r_scale_
        return xyz

    def save(self, path: str | Path) -> Path:
        """Write cameras, scalers, config and network weights to one torch file."""
        if not hasattr(self, 'model_'):
            msg = 'ResidualReconstructor: not fitted; nothing to save'
            raise NotFittedError(msg)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        cams = [c.to_dict() for c in self.base_.cameras_]
        torch.save({'format': MODEL_FORMAT, 'config': json.dumps(self.get_params()),
                    'cameras': json.dumps(cams), 'x_scaler': self.x_scaler_.to_dict(),
                    'p_scaler': self.p_scaler_.to_dict(), 'r_scale': self.r_scale_,
                    'loss_curve': self.loss_curve_,
                    'state_dict': {k: v.cpu() for k, v in self.model_.state_dict().items()}},
                   path)
        return path

    @classmethod
    def load(cls, path: str | Path, device: str = 'auto') -> ResidualReconstructor:
        """Read a file written by ``save``.

        Raises:
            ModelFileError: missing, corrupt or not a residual model file.
        """
        from dempath_calib.camera import CameraModel

        data = read_model_file(path, MODEL_FORMAT)
        try:
            params = json.loads(data['config'])
            params['device'] = device
            est = cls(**params)
            cams = [CameraModel.from_dict(c) for c in json.loads(data['cameras'])]
            est.base_ = DLTTriangulator(refine=est.refine).fit(calibration=cams)
            est.model_ = build_mlp(7, est.hidden_sizes, 3, 0.0)
            est.model_.load_state_dict(data['state_dict'])
            est.x_scaler_ = MinMaxScaler.from_dict(data['x_scaler'])
            est.p_scaler_ = MinMaxScaler.from_dict(data['p_scaler'])
            est.r_scale_ = float(data['r_scale'])
        except (KeyError, TypeError, ValueError, RuntimeError) as err:
            msg = f'{str(path)!r}: malformed residual model file ({type(err).__name__}: {err})'
            raise ModelFileError(msg) from err
        est.device_ = resolve_device(device)
        est.model_.to(est.device_).eval()
        est.loss_curve_ = list(data.get('loss_curve', []))
        est.n_iter_, est.n_features_in_ = len(est.loss_curve_), 4
        return est
