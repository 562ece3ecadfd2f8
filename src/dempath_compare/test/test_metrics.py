"""Each formula of the paper (eqs. 1-5, Table 7) pinned on small hand-computed cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dempath_compare.config import CompareConfig, Matching
from dempath_compare.metrics import (
    dtw_path,
    nearest_distances,
    nrmse,
    rmse,
    s_mean,
    s_sum,
    score_pair,
    trajectory_range,
    weighted_distances,
)

EXP = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
MODEL = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])


def test_weighted_distance_uses_z_weight(strict_numpy: None) -> None:
    """d = sqrt(dx^2 + dy^2 + w dz^2): a (1, 2, 2) offset gives 3 for w=1 and sqrt(13) for w=2."""
    a, b = np.zeros((1, 3)), np.array([[1.0, 2.0, 2.0]])
    assert weighted_distances(a, b, 1.0)[0, 0] == pytest.approx(3.0)
    assert weighted_distances(a, b, 2.0)[0, 0] == pytest.approx(math.sqrt(13.0))
    assert weighted_distances(a, b, 0.25)[0, 0] == pytest.approx(math.sqrt(1 + 4 + 1))


def test_dtw_distance_and_path_by_hand(strict_numpy: None) -> None:
    """DTW of (0,1,2) vs (0,2) along X: the middle point costs 1^2, so DTW = sqrt(1) = 1."""
    distance, path = dtw_path(EXP, MODEL)
    assert distance == pytest.approx(1.0)
    assert path[0] == (0, 0) and path[-1] == (2, 1) and len(path) == 3


def test_dtw_is_root_of_summed_squared_cost(strict_numpy: None) -> None:
    """Four points along Z, offset across by (3, 4, 0): every pair costs 25, DTW = sqrt(100)."""
    a = np.array([[0.0, 0.0, float(k)] for k in range(4)])
    distance, path = dtw_path(a, a + np.array([3.0, 4.0, 0.0]))
    assert distance == pytest.approx(10.0)
    assert path == [(0, 0), (1, 1), (2, 2), (3, 3)]


def test_nearest_distances_spatial_and_along_path(strict_numpy: None) -> None:
    """Nearest over all points: (0, 1, 0); along the DTW path the middle point's pair is 1 away."""
    assert nearest_distances(EXP, MODEL, 1.0).tolist() == pytest.approx([0.0, 1.0, 0.0])
    _, path = dtw_path(EXP, MODEL)
    assert nearest_distances(EXP, MODEL, 1.0, path).tolist() == pytest.approx([0.0, 1.0, 0.0])


def test_path_matching_differs_from_spatial_nearest(strict_numpy: None) -> None:
    """A model passing the last experimental point early: spatial nearest finds it, DTW not."""
    exp = np.array([[0.0, 0, 0], [0, 0, 1.0], [0, 0, 2.0]])
    model = np.array([[0.0, 0, 0], [0, 0, 2.0], [0, 3.0, 2.0], [0, 3.0, 3.0]])
    spatial = nearest_distances(exp, model, 1.0)
    _, path = dtw_path(exp, model)
    along = nearest_distances(exp, model, 1.0, path)
    assert spatial.tolist() == pytest.approx([0.0, 1.0, 0.0])
    assert along[2] > spatial[2]


def test_sum_mean_rmse(strict_numpy: None) -> None:
    """d = (3, 4): S_sum 7, S_mean (MAE) 3.5, RMSE sqrt(12.5)."""
    d = np.array([3.0, 4.0])
    assert s_sum(d) == pytest.approx(7.0)
    assert s_mean(d) == pytest.approx(3.5)
    assert rmse(d) == pytest.approx(math.sqrt(12.5))


def test_range_extent_and_length(strict_numpy: None) -> None:
    """An L path (0,0,0)->(0,0,3)->(0,4,3): extent = 5 (box diagonal), length = 7."""
    p = np.array([[0.0, 0, 0], [0, 0, 3.0], [0, 4.0, 3.0]])
    assert trajectory_range(p, 'extent') == pytest.approx(5.0)
    assert trajectory_range(p, 'length') == pytest.approx(7.0)


def test_nrmse_reproduces_paper_table7_rows() -> None:
    """nRMSE = RMSE / range * 100: Table 7 rows 10.78/216.80 -> 4.97 %, 28.92/258.82 -> 11.17 %."""
    assert nrmse(10.78, 216.80) == pytest.approx(4.97, abs=0.005)
    assert nrmse(28.92, 258.82) == pytest.approx(11.17, abs=0.005)
    assert math.isnan(nrmse(1.0, 0.0))


def test_score_pair_hand_case(strict_numpy: None) -> None:
    """The whole pair score of the (0,1,2)/(0,2) case: DTW 1, S_sum 1, MAE 1/3, RMSE sqrt(1/3)."""
    score = score_pair(EXP, MODEL, CompareConfig(matching=Matching.DTW))
    assert score.dtw == pytest.approx(1.0)
    assert score.s_sum == pytest.approx(1.0)
    assert score.s_mean == pytest.approx(1.0 / 3.0)
    assert score.rmse == pytest.approx(math.sqrt(1.0 / 3.0))
    assert score.n_points == 3
