"""The evaluation figures: known-value metrics, the paper's split, the table's paper column."""

from __future__ import annotations

import numpy as np

from dempath_recon.methods.evaluation import (
    PAPER_TABLE5,
    MethodResult,
    best_method,
    error_metrics,
    fastest_meeting,
    holdout_split,
    markdown_table,
)


def test_paper_split_sizes() -> None:
    """94,939 rows split into 90,790 training and 4,149 test rows, disjoint and complete."""
    train, test = holdout_split(94_939, seed=0)
    assert (len(train), len(test)) == (90_790, 4_149)
    assert len(np.union1d(train, test)) == 94_939


def test_error_metrics_known_values() -> None:
    """Errors of 3, 4 and 12 mm along known axes: mean, SD, max and R2 by hand."""
    truth = np.array([[0.0, 0, 0], [1, 1, 1], [2, 0, 1], [0, 2, 2]])
    pred = truth + np.array([[0.003, 0, 0], [0, 0.004, 0], [0, 0, 0.012], [0, 0, 0]])
    m = error_metrics(pred, truth)
    err = np.array([3.0, 4.0, 12.0, 0.0])
    assert np.isclose(m['mean_mm'], err.mean()) and np.isclose(m['max_mm'], 12.0)
    assert np.isclose(m['sd_mm'], err.std(ddof=1))
    ss_tot = ((truth - truth.mean(axis=0)) ** 2).sum(axis=0)
    expected = 1 - np.array([0.003**2, 0.004**2, 0.012**2]) / ss_tot
    assert np.allclose(m['r2'], expected)


def test_table_and_choices() -> None:
    """The table carries the paper's figures; best = lowest mean; fastest meeting the target."""
    rows = [MethodResult('a', 0.3, 0.1, 1.0, [1, 1, 1], 50.0, 1e5, 10),
            MethodResult('b', 0.2, 0.1, 4.0, [1, 1, 1], 1.0, 1e5, 10),
            MethodResult('c', 0.4, 0.1, 2.0, [1, 1, 1], 5.0, 1e5, 10)]
    table = markdown_table(rows)
    assert f'| max 3D error [mm] | {PAPER_TABLE5["max_mm"]} | 1.000 | 4.000 | 2.000 |' in table
    assert '| R2 Z | 0.9988 |' in table
    assert best_method(rows) == 'b'
    assert fastest_meeting(rows, 0.5, 3.0) == 'c'
