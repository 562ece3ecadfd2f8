"""The paper's Table 7: per marker MAE, RMSE, range and nRMSE over the N best model trajectories.

Kuře & Kuřetová 2025, Table 7: for each tracked marker, MAE and RMSE as mean +/- spread over the
N best model trajectories, the range of the measured trajectory and nRMSE = mean RMSE / range
[%]; then the mean nRMSE per tool speed (the paper: 4.7 % at 1 m/s, 9.41 % at 1.5 m/s).
The spread is the standard deviation over the N best (ddof = 0).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from dempath_compare.runinfo import speed_from_name, speed_text
from dempath_compare.scoring import CompareResult

PAPER_MEAN_NRMSE = {'1 m/s': 4.7, '1.5 m/s': 9.41}  # Table 7 / abstract of the paper [%]


class Table7Row(NamedTuple):
    """One marker of Table 7 (SI units: m; nRMSE in %)."""

    group: str
    speed: str
    marker: int
    label: str
    n_best: int
    mae_mean: float
    mae_std: float
    rmse_mean: float
    rmse_std: float
    range_m: float
    nrmse: float


class Table7(NamedTuple):
    """Rows per marker and the mean nRMSE [%] per tool speed (or experiment group)."""

    rows: list[Table7Row]
    mean_nrmse: dict[str, float]


def speed_label(group: str) -> str:
    """The name convention alone: 'experiment_1p5ms' -> '1.5 m/s', else the name."""
    return speed_text(speed_from_name(group), group)


def build_table7(result: CompareResult, top_n: int | None = None) -> Table7:
    """Table 7 of a comparison: one row per measured marker with at least one ranked model."""
    scores, measured = result.scores, result.measured
    rows = []
    for e in range(len(measured)):
        best = result.best(e, top_n)
        if len(best) == 0:
            continue
        mae, rmse = scores.s_mean[e, best], scores.rmse[e, best]
        range_m = float(scores.ranges[e])
        nrmse = float(np.mean(rmse)) / range_m * 100.0 if range_m > 0 else float('nan')
        rows.append(Table7Row(measured.groups[e],
                              speed_text(float(measured.speeds[e]), measured.groups[e]),
                              int(measured.idents[e]), measured.labels[e], len(best),
                              float(np.mean(mae)), float(np.std(mae)), float(np.mean(rmse)),
                              float(np.std(rmse)), range_m, nrmse))
    means: dict[str, list[float]] = {}
    for row in rows:
        means.setdefault(row.speed, []).append(row.nrmse)
    return Table7(rows, {k: float(np.mean(v)) for k, v in means.items()})


def table7_markdown(table: Table7) -> str:
    """Table 7 as Markdown, in millimetres like the paper."""
    lines = ['| tool speed | marker | N | MAE (mm) | RMSE (mm) | trajectory range (mm) '
             '| nRMSE (%) |',
             '| --- | ---: | ---: | ---: | ---: | ---: | ---: |']
    for r in table.rows:
        lines.append(f'| {r.speed} | {r.marker} | {r.n_best} | {r.mae_mean * 1e3:.2f} ± '
                     f'{r.mae_std * 1e3:.2f} | {r.rmse_mean * 1e3:.2f} ± {r.rmse_std * 1e3:.2f} | '
                     f'{r.range_m * 1e3:.2f} | {r.nrmse:.2f} |')
    lines.append('')
    for speed, value in table.mean_nrmse.items():
        paper = PAPER_MEAN_NRMSE.get(speed)
        ref = f' (paper: {paper:g} %)' if paper is not None else ''
        lines.append(f'- mean nRMSE at {speed}: **{value:.2f} %**{ref}')
    return '\n'.join(lines) + '\n'
