"""Bad trajectories are reported one by one (never a crash, the rest scored); bad sources fail
with one clear error line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath_compare.cli import compare_main
from dempath_compare.errors import InputError
from dempath_compare.loaders import load_source
from dempath_compare.pipeline import compare_paths, problems
from dempath_compare.records import MEASURED


def rows_measured(marker: int, t: np.ndarray, scale: float = 1.0) -> list[str]:
    """CSV rows of a marker pushed 0.1 m forward and lifted 20 mm (times as given)."""
    s = np.linspace(0.0, 1.0, len(t))
    return [f'{ti:.3f},{marker},{0.0:.5f},{0.02 * si * scale:.5f},{0.1 * si * scale:.5f}'
            for ti, si in zip(t, s, strict=True)]


def rows_model(pid: int, marker: int, moving: bool = True, n: int = 20,
               scale: float = 1.0) -> list[str]:
    """CSV rows of a model particle: 5 rest samples, then (if moving) the measured motion."""
    s = np.clip((np.arange(n) - 4) / (n - 5), 0.0, 1.0) if moving else np.zeros(n)
    return [f'{0.01 * i:.3f},{pid},{marker},0.0,{0.02 * si * scale:.5f},{0.1 * si * scale:.5f}'
            for i, si in enumerate(s)]


@pytest.fixture
def bad_folder(tmp_path: Path) -> Path:
    """One good marker and one of each bad case, on both sides."""
    t = np.arange(12) * 0.02
    meas = ['t,marker,x,y,z', *rows_measured(7, t)]
    nan_rows = rows_measured(8, t)
    nan_rows[3] = '0.060,8,nan,nan,nan'
    meas += nan_rows
    meas += rows_measured(11, t[:2])
    meas += rows_measured(42, t)
    meas += rows_measured(12, np.r_[t[:5], t[4:11]])
    meas += rows_measured(13, t[[0, 1, 3, 2, *range(4, 12)]])
    meas += rows_measured(14, t, scale=1000.0)
    (tmp_path / 'experiment_1ms.csv').write_text('\n'.join(meas) + '\n')
    model = ['t,id,marker,x,y,z', *rows_model(1, 7), *rows_model(2, 8), *rows_model(3, 7, False),
             *rows_model(4, 7, n=7)[:2], *rows_model(5, 7, scale=1000.0), *rows_model(6, 99)]
    (tmp_path / 'model_1ms.csv').write_text('\n'.join(model) + '\n')
    return tmp_path


def test_each_bad_trajectory_reported_rest_scored(bad_folder: Path) -> None:
    """NaN (dropped, noted), <3 points, unknown marker, duplicated / unsorted times, millimetres,
    no start of motion: each named on its trajectory; markers 7 and 8 are still scored."""
    result = compare_paths(bad_folder, bad_folder)
    found = {p.label: p for p in problems(result)}
    expect = {'experiment_1ms/marker11': 'need at least 3',
              'experiment_1ms/marker42': 'does not exist',
              'experiment_1ms/marker12': 'duplicated time stamp',
              'experiment_1ms/marker13': 'not increasing',
              'experiment_1ms/marker14': 'millimetres',
              'model_1ms/3': 'no detectable start of motion',
              'model_1ms/4': 'need at least 3',
              'model_1ms/5': 'millimetres',
              'model_1ms/6': 'marker number 99 does not exist'}
    for label, words in expect.items():
        assert words in found[label].problem, (label, found.get(label))
    assert found['experiment_1ms/marker8'].problem == ''
    assert 'NaN' in found['experiment_1ms/marker8'].note
    labels = list(result.measured.labels)
    for marker, model_index in (('experiment_1ms/marker7', 0), ('experiment_1ms/marker8', 1)):
        e = labels.index(marker)
        assert result.best(e).tolist() == [model_index]
        assert result.scores.s_mean[e, model_index] < 0.002


def test_bad_trajectories_listed_in_workbook(bad_folder: Path, tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    """The CLI succeeds and the workbook's problems sheet names every bad trajectory."""
    from openpyxl import load_workbook

    out = tmp_path / 'out'
    assert compare_main([str(bad_folder), str(bad_folder), '--out', str(out), '--no-plots']) == 0
    sheet = load_workbook(out / 'compare.xlsx')['problems']
    listed = {row[1]: row[2] for row in sheet.iter_rows(min_row=2, values_only=True)}
    assert 'millimetres' in listed['experiment_1ms/marker14']
    assert 'no detectable start' in listed['model_1ms/3']
    assert 'experiment_1ms/marker42: marker number 42' in capsys.readouterr().out


@pytest.mark.parametrize('case', ['empty', 'missing', 'binary', 'columns', 'text'])
def test_bad_source_one_error_line(case: str, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    """Empty folder, missing path, unreadable or malformed file: exit 1 with one error line."""
    src = tmp_path / 'src'
    src.mkdir()
    target, words = src, 'no CSV files'
    if case == 'missing':
        target, words = tmp_path / 'nope', 'no such file'
    elif case == 'binary':
        (src / 'experiment_a.csv').write_bytes(b'\xff\xfe\x00\x81garbage')
        words = 'cannot read CSV'
    elif case == 'columns':
        (src / 'experiment_a.csv').write_text('t,marker,x,y\n0,1,0,0\n')
        words = 'missing column'
    elif case == 'text':
        (src / 'experiment_a.csv').write_text('t,marker,x,y,z\n0,1,zero,0,0\n')
        words = 'non-numeric'
    code = compare_main([str(target), str(target), '--out', str(tmp_path / 'out')])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert len(err) == 1 and err[0].startswith('error: ') and words in err[0], err


def test_loader_rejects_empty_folder(tmp_path: Path) -> None:
    """The core raises InputError naming the folder."""
    with pytest.raises(InputError, match=str(tmp_path)):
        load_source(tmp_path, MEASURED)


def test_measured_csv_without_marker_column_names_it(tmp_path: Path) -> None:
    """Rows of several markers in a CSV without a marker column: one error naming the missing
    column (it used to read as 'marker 0: duplicated time stamps')."""
    path = tmp_path / 'measured.csv'
    rows = [r.split(',', 2)[0] + ',' + r.split(',', 2)[2]
            for m in (1, 2) for r in rows_measured(m, np.arange(5) * 0.02)]
    path.write_text('\n'.join(['t,x,y,z', *rows]) + '\n')
    with pytest.raises(InputError, match="no 'marker' column, and its times repeat"):
        load_source(path, MEASURED)


def test_unrecovered_bag_says_to_recover_it(tmp_path: Path) -> None:
    """A bag folder without metadata.yaml (a cut-off recording) names bag-recover instead of
    'no CSV files in folder'."""
    (tmp_path / 'rec').mkdir()
    (tmp_path / 'rec' / 'rec_0.mcap').write_bytes(b'\x89MCAP0\r\n')
    with pytest.raises(InputError, match='dempath bag-recover'):
        load_source(tmp_path / 'rec', MEASURED)
