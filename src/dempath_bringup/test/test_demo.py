"""``dempath demo``'s inputs and its check of the live scores against the recorded bag."""

from __future__ import annotations

from pathlib import Path

import pytest

from dempath.errors import DempathError
from dempath_bringup.demo import demo_main
from dempath_bringup.stages import table7_gap
from dempath_compare.summary import Table7, Table7Row

BAGS = Path(__file__).resolve().parents[3] / 'bags'  # the repository's shipped recordings


def one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    """The single stderr line of a failed command."""
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith('error: ')
    return err[0]


def test_demo_names_a_missing_bag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A field bag that does not exist gives one error line naming it and exit code 1."""
    missing = tmp_path / 'no_such_bag'
    assert demo_main(['--data', str(BAGS), '--field-bag', str(missing),
                      '--out', str(tmp_path / 'out')]) == 1
    assert 'no_such_bag' in one_error_line(capsys)


def test_demo_names_a_missing_data_folder(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """Without the data folder the demo says which folder and how to give it."""
    assert demo_main(['--data', str(tmp_path / 'nowhere'), '--out', str(tmp_path / 'o')]) == 1
    line = one_error_line(capsys)
    assert 'nowhere' in line and '--data' in line


def table(nrmse: dict[int, float]) -> Table7:
    """A Table 7 with the given nRMSE [%] per marker (other columns irrelevant here)."""
    rows = [Table7Row('g', '1 m/s', m, f'g/marker{m}', 10, 0.0, 0.0, 0.0, 0.0, 0.1, v)
            for m, v in nrmse.items()]
    return Table7(rows, {})


def test_live_and_recorded_table7_must_agree() -> None:
    """Equal tables pass with their gap; another marker set or another score is an error."""
    assert table7_gap(table({1: 5.0, 2: 7.0}), table({1: 5.0, 2: 7.0})) == 0.0
    with pytest.raises(DempathError, match='markers'):
        table7_gap(table({1: 5.0}), table({1: 5.0, 2: 7.0}))
    with pytest.raises(DempathError, match='differ'):
        table7_gap(table({1: 5.0}), table({1: 5.5}))
