"""Tabular outputs: score rows, CSV files and the Excel workbook (openpyxl).

The workbook has a summary sheet (Table 7, the mean nRMSE per tool speed, the settings and every
trajectory with a problem), one sheet per measured trajectory with its ranked model trajectories,
and a problems sheet.
"""

from __future__ import annotations

import csv
import re
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from dempath.errors import OutputError
from dempath_compare.pipeline import problems
from dempath_compare.scoring import CompareResult
from dempath_compare.summary import Table7

SCORE_COLUMNS = ('experiment', 'marker', 'rank', 'model', 'model_run', 'particle_id',
                 'dtw_m', 's_sum_m', 'mae_m', 'rmse_m', 'range_m', 'nrmse_pct', 'n_points')
TABLE7_COLUMNS = ('tool_speed', 'marker', 'experiment', 'n_best', 'mae_mean_mm', 'mae_std_mm',
                  'rmse_mean_mm', 'rmse_std_mm', 'range_mm', 'nrmse_pct')


def score_rows(result: CompareResult, e: int | None = None) -> list[tuple[Any, ...]]:
    """Rows of SCORE_COLUMNS for each compared pair (of experiment ``e`` if given), by rank."""
    s, meas, mod = result.scores, result.measured, result.model
    nrmse = s.nrmse
    rows = []
    for i in range(len(meas)) if e is None else [e]:
        order = result.best(i, n=len(mod))
        for j in order:
            rows.append((meas.labels[i], int(meas.idents[i]), int(s.rank[i, j]), mod.labels[j],
                         mod.groups[j], int(mod.idents[j]), float(s.dtw[i, j]),
                         float(s.s_sum[i, j]), float(s.s_mean[i, j]), float(s.rmse[i, j]),
                         float(s.ranges[i]), float(nrmse[i, j]), int(meas.lengths[i])))
    return rows


def table7_rows(table: Table7) -> list[tuple[Any, ...]]:
    """Rows of TABLE7_COLUMNS (millimetres like the paper)."""
    return [(r.speed, r.marker, r.label, r.n_best, r.mae_mean * 1e3, r.mae_std * 1e3,
             r.rmse_mean * 1e3, r.rmse_std * 1e3, r.range_m * 1e3, r.nrmse) for r in table.rows]


def write_csv(path: Path, header: tuple[str, ...], rows: list[tuple[Any, ...]]) -> Path:
    """Write one CSV file (floats with full precision)."""
    try:
        with path.open('w', newline='') as handle:
            writer = csv.writer(handle)
            writer.writerow(header)
            writer.writerows(rows)
    except OSError as err:
        msg = f'{path}: cannot write CSV ({err})'
        raise OutputError(msg) from err
    return path


def sheet_title(label: str, used: set[str]) -> str:
    """An Excel-safe, unique sheet title (<= 31 characters, no []:*?/\\)."""
    base = re.sub(r'[\[\]:*?/\\]', '_', label)[-31:] or 'sheet'
    title, k = base, 2
    while title.lower() in used:
        suffix = f'~{k}'
        title, k = base[: 31 - len(suffix)] + suffix, k + 1
    used.add(title.lower())
    return title


def write_workbook(path: Path, result: CompareResult, table: Table7) -> Path:
    """Write the xlsx workbook: summary, one sheet per measured trajectory, problems."""
    from openpyxl import Workbook
    from openpyxl.styles import Font

    book = Workbook()
    summary = book.active
    summary.title = 'summary'
    used = {'summary', 'problems'}
    bold = Font(bold=True)
    summary.append(['Table 7: error metrics over the N best model trajectories'])
    summary['A1'].font = bold
    _append_table(summary, TABLE7_COLUMNS, table7_rows(table), bold)
    summary.append([])
    for speed, value in table.mean_nrmse.items():
        summary.append(['mean nRMSE [%]', speed, value])
    summary.append([])
    summary.append(['settings'])
    for key, value in asdict(result.config).items():
        summary.append([key, str(getattr(value, 'value', value))])
    summary.append([])
    summary.append(['trajectories with problems (not scored) or notes'])
    _append_table(summary, ('kind', 'trajectory', 'problem', 'note'),
                  [tuple(p) for p in problems(result)], bold)
    for e, label in enumerate(result.measured.labels):
        sheet = book.create_sheet(sheet_title(label, used))
        sheet.append([label, result.measured.problems[e] or 'scored'])
        _append_table(sheet, SCORE_COLUMNS, score_rows(result, e), bold)
    sheet = book.create_sheet('problems')
    _append_table(sheet, ('kind', 'trajectory', 'problem', 'note'),
                  [tuple(p) for p in problems(result)], bold)
    try:
        book.save(path)
    except OSError as err:
        msg = f'{path}: cannot write workbook ({err})'
        raise OutputError(msg) from err
    return path


def _append_table(sheet: Any, header: tuple[str, ...], rows: list[tuple[Any, ...]],
                  bold: Any) -> None:
    sheet.append(list(header))
    for cell in sheet[sheet.max_row]:
        cell.font = bold
    for row in rows:
        sheet.append([None if isinstance(v, float) and not np.isfinite(v) else v for v in row])
