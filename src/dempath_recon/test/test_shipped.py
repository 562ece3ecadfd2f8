"""The trained MLP shipped with dempath_recon: the file as loaded, its accuracy, its use."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
import torch

from dempath_calib.pointset import PointSet
from dempath_recon.cli import reconstruct_main
from dempath_recon.methods.mlp import MLPReconstructor
from dempath_recon.methods.registry import load_reconstructor
from dempath_recon.methods.shipped import SHIPPED_MODEL, load_shipped_mlp
from dempath_twin.board.recording import synthetic_point_set

MEAN_MM, MAX_MM = 0.5, 5.0  # the targets for the held-out rows of the twin


@pytest.fixture(scope='module')
def shipped() -> MLPReconstructor:
    """The shipped network as ``dempath reconstruct --method mlp`` loads it."""
    return load_shipped_mlp()


@pytest.fixture(scope='module')
def fresh() -> PointSet:
    """2,000 twin samples (0.2 px corner noise) from board poses the network never saw."""
    return synthetic_point_set(2000, noise_px=0.2, seed=7)


def test_shipped_network_meets_the_accuracy_on_unseen_twin_points(shipped, fresh) -> None:
    """Mean <= 0.5 mm and max <= 5 mm on twin points from poses outside the training set."""
    err = np.linalg.norm(shipped.predict(fresh.pixels) - fresh.xyz, axis=1) * 1e3
    assert err.mean() <= MEAN_MM, err.mean()
    assert err.max() <= MAX_MM, err.max()


def test_shipped_file_is_small_float16_and_round_trips(shipped, fresh, tmp_path) -> None:
    """float16 weights, a few MB; saving the loaded network again gives the same weights."""
    assert SHIPPED_MODEL.stat().st_size < 6e6
    stored = torch.load(SHIPPED_MODEL, weights_only=True)
    assert all(v.dtype == torch.float16 for v in stored['state_dict'].values())
    assert {**json.loads(stored['config']), 'device': 'cpu'} == shipped.get_params()
    assert shipped.hidden_sizes == (2048, 1024, 512)
    again = MLPReconstructor.load(shipped.save(tmp_path / 'again.pt', weights='float16'),
                                  device='cpu')
    resaved = torch.load(tmp_path / 'again.pt', weights_only=True)['state_dict']
    assert all(torch.equal(resaved[k], v) for k, v in stored['state_dict'].items())
    assert np.array_equal(again.predict(fresh.pixels), shipped.predict(fresh.pixels))


def test_shipped_provenance_states_the_rig_and_the_loaded_accuracy() -> None:
    """The JSON beside the file: twin rig only, the paper's split, the file's figures."""
    info = json.loads(SHIPPED_MODEL.with_suffix('.json').read_text())
    assert 'twin rig' in info['note'] and 'recon-train' in info['note']
    assert info['data']['samples'] == 94_939 and info['data']['held_out_rows'] == 4_149
    assert info['held_out_as_loaded']['mean_mm'] <= MEAN_MM
    assert info['held_out_as_loaded']['max_mm'] <= MAX_MM


def test_mlp_without_a_model_file_uses_the_shipped_network(fresh, tmp_path, capsys) -> None:
    """load_reconstructor and `dempath reconstruct --method mlp` need no --model for the twin."""
    est = load_reconstructor('mlp', device='cpu')
    assert isinstance(est, MLPReconstructor)
    px = tmp_path / 'px.csv'
    with open(px, 'w', newline='') as fh:
        w = csv.writer(fh)
        w.writerow(['marker', 'xs', 'ys', 'xf', 'yf'])
        w.writerows([k, *row] for k, row in enumerate(fresh.pixels[:50]))
    out = tmp_path / 'xyz.csv'
    assert reconstruct_main([str(px), '--method', 'mlp', '--out', str(out)]) == 0
    assert 'twin rig' in capsys.readouterr().err
    with open(out, newline='') as fh:
        xyz = np.array([[float(r[c]) for c in 'xyz'] for r in csv.DictReader(fh)])
    assert np.linalg.norm(xyz - fresh.xyz[:50], axis=1).max() < MAX_MM * 1e-3
