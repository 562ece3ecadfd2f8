"""The paper's network: architecture, both training recipes, persistence, bad files."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from torch import nn

from dempath_recon.errors import ModelFileError, NotFittedError
from dempath_recon.methods.evaluation import PAPER_TABLE5
from dempath_recon.methods.mlp import PAPER_RECIPE, MLPReconstructor
from dempath_recon.methods.residual import ResidualReconstructor


@pytest.fixture(scope='module')
def small_mlp(points) -> MLPReconstructor:
    """A small (256, 256) network, default recipe, 40 epochs on 3,000 samples (seconds)."""
    return MLPReconstructor(hidden_sizes=(256, 256), epochs=40, batch_size=128,
                            random_state=0, device='cpu').fit(points.pixels[:3000],
                                                              points.xyz[:3000])


def _fit_tiny(est: MLPReconstructor) -> MLPReconstructor:
    rng = np.random.default_rng(0)
    return est.fit(rng.uniform(0, 1000, (64, 4)), rng.normal(size=(64, 3)))


def test_default_architecture_is_the_papers_with_dempaths_recipe() -> None:
    """Defaults: 4 -> 2048 -> 1024 -> 512 -> 3 with ReLU; standardised, AdamW, one-cycle."""
    est = _fit_tiny(MLPReconstructor(epochs=1, random_state=0, device='cpu'))
    linear = [m for m in est.model_ if isinstance(m, nn.Linear)]
    assert [(m.in_features, m.out_features) for m in linear] == \
        [(4, 2048), (2048, 1024), (1024, 512), (512, 3)]
    assert [type(m).__name__ for m in est.model_] == ['Linear', 'ReLU'] * 3 + ['Linear']
    default = MLPReconstructor()
    assert (default.batch_size, default.epochs, default.validation_fraction, default.dropout,
            default.optimizer, default.schedule, default.scaling, default.hidden_sizes) == \
        (512, 10, 0.0, 0.0, 'adamw', 'onecycle', 'standard', (2048, 1024, 512))


def test_paper_recipe_is_reachable() -> None:
    """paper_recipe(): Dropout(0.2) after each hidden layer, Adam, 60 epochs, split 0.2."""
    est = _fit_tiny(MLPReconstructor.paper_recipe(epochs=1, random_state=0, device='cpu'))
    assert [type(m).__name__ for m in est.model_] == ['Linear', 'ReLU', 'Dropout'] * 3 + \
        ['Linear']
    assert all(m.p == 0.2 for m in est.model_ if isinstance(m, nn.Dropout))
    paper = MLPReconstructor.paper_recipe()
    assert (paper.batch_size, paper.epochs, paper.patience, paper.validation_fraction,
            paper.optimizer, paper.schedule, paper.scaling) == \
        (512, 60, 10, 0.2, 'adam', 'constant', 'minmax')
    assert {k: paper.get_params()[k] for k in PAPER_RECIPE} == PAPER_RECIPE


def test_get_params_lists_every_constructor_argument() -> None:
    """get_params (shared by both learned methods) holds every __init__ argument, JSON-able."""
    for cls in (MLPReconstructor, ResidualReconstructor):
        est = cls(hidden_sizes=(8, 4), random_state=5)
        params = est.get_params()
        assert list(params) == cls.param_names()
        assert params['hidden_sizes'] == [8, 4] and params['random_state'] == 5
        assert cls(**params).get_params() == params


def test_scalers_standardise_or_map_to_unit_interval(small_mlp, points) -> None:
    """Default: zero mean, unit SD over the training rows; paper recipe: exactly 0..1."""
    scaled = small_mlp.x_scaler_.transform(points.pixels[:3000])
    assert np.allclose(scaled.mean(axis=0), 0) and np.allclose(scaled.std(axis=0), 1)
    back = small_mlp.y_scaler_.inverse_transform(small_mlp.y_scaler_.transform(points.xyz))
    assert np.allclose(back, points.xyz)
    paper = MLPReconstructor.paper_recipe(hidden_sizes=(8,), epochs=1, device='cpu')
    paper.fit(points.pixels[:500], points.xyz[:500])
    scaled = paper.x_scaler_.transform(points.pixels[:500])
    assert np.allclose(scaled.min(axis=0), 0) and np.allclose(scaled.max(axis=0), 1)


def test_small_network_beats_the_papers_accuracy(small_mlp, points) -> None:
    """From 3,000 samples in seconds: held-out mean and max below the paper's Table 5."""
    err = np.linalg.norm(small_mlp.predict(points.pixels[3000:]) - points.xyz[3000:],
                         axis=1) * 1e3
    assert err.mean() < PAPER_TABLE5['mean_mm'], err.mean()
    assert err.max() < PAPER_TABLE5['max_mm'], err.max()
    assert small_mlp.n_iter_ == len(small_mlp.loss_curve_) == small_mlp.best_epoch_ == 40
    assert small_mlp.validation_curve_ == []
    assert small_mlp.loss_curve_[-1] < 0.01 * small_mlp.loss_curve_[0]


def test_early_stopping_restores_the_best_weights(points) -> None:
    """With patience 2 training stops early and the kept weights are the best epoch's."""
    est = MLPReconstructor(hidden_sizes=(32,), epochs=200, batch_size=32, patience=2,
                           learning_rate=0.05, validation_fraction=0.2, optimizer='adam',
                           schedule='constant', random_state=3, device='cpu')
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
    """Saved and loaded network predicts the same (float32) values, with the same config."""
    path = small_mlp.save(tmp_path / 'mlp.pt')
    loaded = MLPReconstructor.load(path, device='cpu')
    assert loaded.get_params() == small_mlp.get_params()
    assert np.array_equal(loaded.predict(points.pixels), small_mlp.predict(points.pixels))


def test_float16_file_is_half_the_size_and_close(small_mlp, points, tmp_path) -> None:
    """float16 weights: about half the file, predictions within 0.1 mm of the float32 net."""
    full = small_mlp.save(tmp_path / 'full.pt')
    half = small_mlp.save(tmp_path / 'half.pt', weights='float16')
    assert half.stat().st_size < 0.6 * full.stat().st_size
    stored = torch.load(half, weights_only=True)['state_dict']
    assert all(v.dtype == torch.float16 for v in stored.values())
    loaded = MLPReconstructor.load(half, device='cpu')
    assert all(p.dtype == torch.float32 for p in loaded.model_.parameters())
    diff = np.linalg.norm(loaded.predict(points.pixels) - small_mlp.predict(points.pixels),
                          axis=1)
    assert diff.max() < 1e-4, diff.max()
    with pytest.raises(ValueError, match='weights'):
        small_mlp.save(tmp_path / 'x.pt', weights='int8')


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
