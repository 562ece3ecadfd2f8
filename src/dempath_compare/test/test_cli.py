"""``dempath compare`` on the worked example: every output exists and is valid."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from dempath_compare.cli import compare_main

PNG_MAGIC = b'\x89PNG\r\n\x1a\n'


def test_cli_outputs_on_worked_example(example_dir: Path, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    """Ranking printed; CSV, Table 7, workbook (8 experiment sheets), PNGs and report written."""
    from openpyxl import load_workbook

    out = tmp_path / 'out'
    code = compare_main([str(example_dir), str(example_dir), '--out', str(out), '--top', '5',
                         '--identity-from-names'])
    printed = capsys.readouterr().out
    assert code == 0
    assert 'experiment_1ms/marker9' in printed and f'workbook: {out / "compare.xlsx"}' in printed
    with (out / 'scores.csv').open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 8 * 12  # 8 markers, 12 Cube candidates each, tagged by marker and speed
    assert {r['rank'] for r in rows if r['experiment'] == 'experiment_1ms/marker9'} == {
        str(k) for k in range(1, 13)}
    book = load_workbook(out / 'compare.xlsx')
    assert book.sheetnames[0] == 'summary' and book.sheetnames[-1] == 'problems'
    assert len(book.sheetnames) == 10
    table7 = (out / 'table7.md').read_text()
    assert table7.count('| 1 m/s |') == 4 and table7.count('| 1.5 m/s |') == 4
    pngs = sorted((out / 'plots').glob('*.png'))
    assert len(pngs) == 8 + 2
    assert all(p.read_bytes()[:8] == PNG_MAGIC and p.stat().st_size > 10_000 for p in pngs)
    report = (out / 'report.md').read_text()
    assert all(f'plots/{p.name}' in report for p in pngs)


def test_cli_options_change_ranking(example_dir: Path, tmp_path: Path) -> None:
    """--rank-by mean and --z-weight reach the scores (nRMSE column differs with w = 4)."""
    out1, out2 = tmp_path / 'a', tmp_path / 'b'
    assert compare_main([str(example_dir), str(example_dir), '--out', str(out1),
                         '--no-plots']) == 0
    assert compare_main([str(example_dir), str(example_dir), '--out', str(out2), '--no-plots',
                         '--rank-by', 'mean', '--z-weight', '4', '--top', '3']) == 0
    first = (out1 / 'table7.csv').read_text().splitlines()
    second = (out2 / 'table7.csv').read_text().splitlines()
    assert first[0] == second[0] and first[1:] != second[1:]
    assert all(line.split(',')[3] == '3' for line in second[1:])


@pytest.mark.parametrize(('args', 'code', 'words'), [
    (['--top', '0'], 1, 'CompareConfig.top_n: invalid value 0'),
    (['--z-weight', '-1'], 1, 'CompareConfig.z_weight'),
    (['--rank-by', 'median'], 2, "invalid choice: 'median'"),
])
def test_cli_bad_options_one_line(example_dir: Path, tmp_path: Path, args: list[str], code: int,
                                  words: str, capsys: pytest.CaptureFixture[str]) -> None:
    """Bad option values end with one error line naming the option and value."""
    argv = [str(example_dir), str(example_dir), '--out', str(tmp_path / 'o'), *args]
    try:
        got = compare_main(argv)
    except SystemExit as exc:
        got = int(exc.code or 0)
    err = capsys.readouterr().err.strip().splitlines()
    assert got == code
    assert len(err) == 1 and err[0].startswith('error: ') and words in err[0], err
