"""Rebuild the shape of the paper's Table 7 from a small fixture with known errors."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_compare.config import CompareConfig
from dempath_compare.pipeline import compare_tracks
from dempath_compare.records import Track
from dempath_compare.summary import build_table7, speed_label, table7_markdown

K = 11  # measured samples: 10 steps of 20 mm along Z (range 0.2 m)
OFFSETS = (0.001, 0.002, 0.003, 0.004, 0.005)  # lateral offsets of the candidates [m]


def measured(group: str, marker: int) -> Track:
    """A straight 0.2 m trajectory along Z starting at the marker's grid position."""
    pos = np.zeros((K, 3))
    pos[:, 2] = np.linspace(0.0, 0.2, K)
    pos += [0.05 * marker, 0.0, 0.0]
    return Track(f'{group}/marker{marker}', group, marker, marker, np.arange(K) * 0.02, pos)


def candidate(run: str, marker: int, ident: int, offset: float) -> Track:
    """5 rest samples, then the measured line shifted across by ``offset`` (after its start)."""
    line = measured(run, marker).positions
    line[1:, 0] += offset
    pos = np.vstack([np.repeat(line[:1], 4, axis=0), line])
    return Track(f'{run}/{ident}', run, ident, marker, np.arange(len(pos)) * 0.02, pos)


def fixture() -> tuple[list[Track], list[Track]]:
    """Two tool speeds (as the loaders fill them), two markers each, five candidates each."""
    meas, model = [], []
    for tag, speed in (('1ms', 1.0), ('1p5ms', 1.5)):
        for marker, scale in ((9, 1.0), (10, 2.0)):
            meas.append(measured(f'experiment_{tag}', marker)._replace(speed_m_s=speed))
            model += [candidate(f'model_{tag}', marker, 1000 * marker + k,
                                scale * off)._replace(speed_m_s=speed)
                      for k, off in enumerate(OFFSETS)]
    return meas, model


def test_table7_rows_and_speed_means(strict_numpy: None) -> None:
    """N = 3 best: MAE = mean(1, 2, 3 mm) * 10/11, nRMSE = mean RMSE / 0.2 m; means per speed."""
    meas, model = fixture()
    result = compare_tracks(meas, model, CompareConfig(top_n=3))
    table = build_table7(result)
    assert [(r.speed, r.marker) for r in table.rows] == [
        ('1 m/s', 9), ('1 m/s', 10), ('1.5 m/s', 9), ('1.5 m/s', 10)]
    frac = (K - 1) / K
    for row in table.rows:
        scale = 1.0 if row.marker == 9 else 2.0
        offsets = scale * np.array(OFFSETS[:3])
        assert row.n_best == 3
        assert row.mae_mean == pytest.approx(np.mean(offsets) * frac)
        assert row.mae_std == pytest.approx(np.std(offsets) * frac)
        assert row.rmse_mean == pytest.approx(np.mean(offsets) * np.sqrt(frac))
        assert row.range_m == pytest.approx(0.2)
        assert row.nrmse == pytest.approx(np.mean(offsets) * np.sqrt(frac) / 0.2 * 100)
    expected = np.mean([r.nrmse for r in table.rows[:2]])
    assert table.mean_nrmse == pytest.approx({'1 m/s': expected, '1.5 m/s': expected})
    text = table7_markdown(table)
    assert '| 1 m/s | 9 | 3 |' in text and '(paper: 9.41 %)' in text


def test_speed_labels() -> None:
    """Tool speeds are read from experiment names in the usual spellings."""
    assert speed_label('experiment_1ms') == '1 m/s'
    assert speed_label('experiment_1p5ms') == '1.5 m/s'
    assert speed_label('experiment_1.5ms') == '1.5 m/s'
    assert speed_label('trial_a') == 'trial_a'


def test_paper_means_from_its_rows() -> None:
    """The paper's own Table 7 nRMSE column averages to its 4.7 % and 9.41 % (our summary rule)."""
    one = [4.97, 6.22, 2.76, 4.98]
    one_half = [3.01, 2.73, 4.58, 3.29, 11.17, 15.85, 17.75, 16.86]
    assert np.mean(one) == pytest.approx(4.7, abs=0.05)
    assert np.mean(one_half) == pytest.approx(9.41, abs=0.01)
