"""The paper's network: architecture, training contract, persistence, bad files."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from torch import nn

from dempath_recon.errors import ModelFileError, NotFittedError
from dempath_recon.mlp import MLPReconstructor
from dempath_recon.residual import ResidualReconstructor


@pytest.fixture(scope='module')
def small_mlp(points) -> MLPReconstructor:
    """A small (128, 128) network trained for at most 40 epochs on 3,000 samples."""
    return MLPReconstructor(hidden_sizes=(128, 128), epochs=40, batch_size=64, dropout=0.0,
                            patience=10, random_state=0, device='cpu').fit(
        points.pixels[:3000], points.xyz[:3000])


def test_default_architecture_is_the_papers() -> None:
    """Defaults: 4 -> 2048 -> 1024 -> 512 -> 3, ReLU + Dropout(0.2) after each hidden layer."""
    est = MLPReconstructor(epochs=1, random_state=0, device='cpu')
    rng = np.random.default_rng(0)
    est.fit(rng.uniform(0, 1000, (64, 4)), rng.normal(size=(64, 3)))
    linear = [m for m in est.model_ if isinstance(m, nn.Linear)]
    assert [(m.in_features, m.out_features) for m in linear] == \
        [(4, 2048), (2048, 1024), (1024, 512), (512, 3)]
    kinds = [type(m).__name__ for m in est.model_]
    assert kinds == ['Linear', 'ReLU', 'Dropout'] * 3 + ['Linear']
    assert all(m.p == 0.2 for m in est.model_ if isinstance(m, nn.Dropout))
    default = MLPReconstructor()
    assert (default.batch_size, default.epochs, default.patience,
            default.validation_fraction, default.hidden_sizes) == (512, 60, 10, 0.2,
                                                                   (2048, 1024, 512))


def test_scalers_map_training_range_to_unit_interval(small_mlp, points) -> None:
    """Inputs and targets are min-max scaled to exactly 0..1 over the training rows."""
    scaled = small_mlp.x_scaler_.transform(points.pixels[:3000])
    assert np.allclose(scaled.min(axis=0), 0) and np.allclose(scaled.max(axis=0), 1)
    back = small_mlp.y_scaler_.inverse_transform(small_mlp.y_scaler_.transform(points.xyz))
    assert np.allclose(back, points.xyz)


def test_small_network_learns_the_mapping(small_mlp, points) -> None:
    """Held-out error falls below 5% of the predict-the-mean baseline; curves are recorded."""
    test_px, test_xyz = points.pixels[3000:], points.xyz[3000:]
    err = np.linalg.norm(small_mlp.predict(test_px) - test_xyz, axis=1).mean()
    baseline = np.linalg.norm(test_xyz - points.xyz[:3000].mean(axis=0), axis=1).mean()
    assert err < 0.05 * baseline
    assert small_mlp.n_iter_ == len(small_mlp.loss_curve_) == len(small_mlp.validation_curve_)
    assert small_mlp.loss_curve_[-1] < small_mlp.loss_curve_[0]


def test_early_stopping_restores_the_best_weights(points) -> None:
    """With patience 2 training stops early and the kept weights are the best epoch's."""
    est = MLPReconstructor(hidden_sizes=(32,), epochs=200, batch_size=32, patience=2,
                           learning_rate=0.05, random_state=3, device='cpu')
    est.fit(points.pixels[:600], points.xyz[:600])
    curve = est.validation_curve_
    assert est.n_iter_ < 200
    assert est.best_epoch_ == int(np.argmin(curve)) + 1
    assert est.n_iter_ == est.best_epoch_ + 2


def test_nan_rows_give_nan(small_mlp, points) -> None:
    """A NaN pixel row gives a NaN point; the other rows are unchanged."""
    px = points.pixels[:5].copy()
    px[2, 1] = np.nan
    out = small_mlp.predict(px)
    assert np.isnan(out[2]).all()
    assert np.allclose(out[[0, 1, 3, 4]], small_mlp.predict(points.pixels[[0, 1, 3, 4]]))


def test_save_load_round_trip(small_mlp, points, tmp_path) -> None:
    """Saved and loaded network predicts the same (float32) values."""
    path = small_mlp.save(tmp_path / 'mlp.pt')
    loaded = MLPReconstructor.load(path, device='cpu')
    assert loaded.hidden_sizes == (128, 128)
    assert np.array_equal(loaded.predict(points.pixels), small_mlp.predict(points.pixels))


def test_bad_model_files_give_one_clear_error(tmp_path, rig, points) -> None:
    """Missing, corrupt and wrong-kind files raise ModelFileError naming the file."""
    with pytest.raises(ModelFileError, match='model file not found'):
        MLPReconstructor.load(tmp_path / 'none.pt')
    corrupt = tmp_path / 'corrupt.pt'
    corrupt.write_bytes(b'\x00not a torch file' * 10)
    with pytest.raises(ModelFileError, match=r'corrupt\.pt'):
        MLPReconstructor.load(corrupt)
    other = tmp_path / 'other.pt'
    torch.save({'format': 'something-else'}, other)
    with pytest.raises(ModelFileError, match="expected a 'dempath-mlp-1'"):
        MLPReconstructor.load(other)
    with pytest.raises(ModelFileError, match='expected a'):
        ResidualReconstructor.load(other)
    with pytest.raises(NotFittedError):
        MLPReconstructor().predict(points.pixels)
