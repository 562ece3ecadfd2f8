"""All outputs of one comparison in a folder, tied together by a Markdown page."""

from __future__ import annotations

import logging
import re
from pathlib import Path
from typing import NamedTuple

from dempath.errors import OutputError
from dempath_compare.export import (
    SCORE_COLUMNS,
    TABLE7_COLUMNS,
    score_rows,
    table7_rows,
    write_csv,
    write_workbook,
)
from dempath_compare.pipeline import problems
from dempath_compare.plots import plot_best, plot_tracked_3d
from dempath_compare.scoring import CompareResult
from dempath_compare.summary import Table7, build_table7, table7_markdown

log = logging.getLogger(__name__)


class Outputs(NamedTuple):
    """Paths of everything written for one comparison."""

    scores_csv: Path
    table7_csv: Path
    table7_md: Path
    workbook: Path
    best_plots: list[Path]
    tracked_plots: list[Path]
    report: Path


def safe_name(label: str) -> str:
    """A file-name-safe version of a trajectory label."""
    return re.sub(r'[^A-Za-z0-9._-]+', '_', label).strip('_') or 'trajectory'


def write_outputs(result: CompareResult, out_dir: str | Path, plots: bool = True) -> Outputs:
    """Write CSVs, workbook, Table 7, PNG figures (unless ``plots`` is False) and ``report.md``.

    Raises:
        OutputError: the folder cannot be created or written.
    """
    out = Path(out_dir)
    try:
        (out / 'plots').mkdir(parents=True, exist_ok=True)
    except OSError as err:
        msg = f'{out}: cannot create output folder ({err})'
        raise OutputError(msg) from err
    table = build_table7(result)
    scores_csv = write_csv(out / 'scores.csv', SCORE_COLUMNS, score_rows(result))
    table7_csv = write_csv(out / 'table7.csv', TABLE7_COLUMNS, table7_rows(table))
    table7_md = out / 'table7.md'
    table7_md.write_text(table7_markdown(table))
    workbook = write_workbook(out / 'compare.xlsx', result, table)
    best = [plot_best(result, e, out / 'plots' / f'{safe_name(label)}_xz_yz.png')
            for e, label in enumerate(result.measured.labels) if plots and len(result.best(e))]
    groups = sorted({g for g, n in zip(result.measured.groups, result.measured.lengths,
                                       strict=True) if n > 0 and plots})
    tracked = [plot_tracked_3d(result, g, out / 'plots' / f'tracked_3d_{safe_name(g)}.png')
               for g in groups]
    outputs = Outputs(scores_csv, table7_csv, table7_md, workbook, best, tracked,
                      out / 'report.md')
    outputs.report.write_text(report_markdown(result, table, outputs))
    log.info('wrote outputs to %s', out)
    return outputs


def report_markdown(result: CompareResult, table: Table7, outputs: Outputs) -> str:
    """The Markdown page: settings, Table 7, figures, problems and the files written."""
    base = outputs.report.parent
    cfg = result.config
    lines = ['# Trajectory comparison', '',
             f'{int(result.measured.valid.sum())} of {len(result.measured)} measured and '
             f'{int(result.model.valid.sum())} of {len(result.model)} model trajectories scored; '
             f'{int(result.scores.compared.sum())} pairs. Ranked by S_{cfg.rank_by.value}, '
             f'N best = {cfg.top_n}, sp = {cfg.sp:g}, Z weight w = {cfg.z_weight:g}, '
             f'matching = {cfg.matching.value}, nRMSE range = {cfg.range_kind.value}.', '',
             '## Table 7 (as in Kuře & Kuřetová 2025)', '', table7_markdown(table),
             '## Tracked trajectories (Figures 11-12)', '']
    lines += [f'![{p.stem}]({p.relative_to(base)})' for p in outputs.tracked_plots]
    lines += ['', '## Measured vs N best model trajectories (Figures 13-16)', '']
    lines += [f'![{p.stem}]({p.relative_to(base)})' for p in outputs.best_plots]
    lines += ['', '## Trajectories with problems or notes', '']
    found = problems(result)
    lines += [f'- {p.kind} `{p.label}`: {p.problem or "scored"}{"; " + p.note if p.note else ""}'
              for p in found] or ['- none']
    lines += ['', '## Files', '']
    for path in (outputs.scores_csv, outputs.table7_csv, outputs.table7_md, outputs.workbook):
        lines.append(f'- [{path.name}]({path.relative_to(base)})')
    return '\n'.join(lines) + '\n'
