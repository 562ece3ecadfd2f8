"""Outputs of a diagnosis: diagnosis.json, report.md, plots, an xlsx and the rich ranking."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from dempath.errors import OutputError
from dempath_diagnose.decision.diagnosis import Diagnosis, sentences
from dempath_diagnose.decision.statistics import AXES, Layout
from dempath_diagnose.decision.verdict import ModelFit

EDGE_NOTE_P = 0.05  # fits this probable get a note when they sit at the range edge


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _finite(value: Any) -> Any:
    """``value`` with every non-finite float (nested in dicts and lists) as None (valid JSON)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    if isinstance(value, float):
        return _num(value)
    return value


def _fit_json(fit: ModelFit) -> dict[str, Any]:
    return {'effect': fit.name, 'kind': fit.kind, 'probability': round(fit.probability, 4),
            'strength': {'parameter': fit.parameter, 'value': _num(fit.strength),
                         'uncertainty': _num(fit.strength_sd), 'best': _num(fit.best),
                         'unit': fit.unit,
                         'range': [_num(fit.strength_range[0]), _num(fit.strength_range[1])],
                         'at_range_edge': fit.at_range_edge},
            'explained_fraction': round(fit.explained_fraction, 4),
            'implausibility': round(fit.implausibility, 3), 'ruled_out': fit.ruled_out}


def to_json(d: Diagnosis, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """The ``diagnosis.json`` content."""
    dec = d.decision
    names = d.emulator.names
    obs_names = [n for n, o in zip(names, d.observed, strict=True) if o]
    idx = np.flatnonzero(d.observed)
    floor = d.floor
    out: dict[str, Any] = {
        'verdict': dec.verdict,
        'summary': sentences(d),
        'ranking': [_fit_json(f) for f in dec.ranking],
        'baseline': _fit_json(dec.baseline),
        'floor': {n: float(floor[i]) for i, n in enumerate(names)},
        'error_before': {
            'statistics': {n: {'measured': float(d.measured[j]),
                               'model': float(d.emulator.mu0[idx[j]]),
                               'difference': float(d.measured[j] - d.emulator.mu0[idx[j]]),
                               'z': float((d.measured[j] - d.emulator.mu0[idx[j]])
                                          / floor[idx[j]])}
                           for j, n in enumerate(obs_names)},
            'markers': {str(int(m)): {a: float(np.sqrt(np.nanmean(d.marker_error[i, :, k] ** 2)))
                                      for k, a in enumerate(AXES)}
                        for i, m in enumerate(d.layout.markers)},
            'mean_abs_z_markers': float(np.nanmean(np.abs(d.marker_z))),
            'table7': _finite({k: v for k, v in d.table7.items() if k != 'markdown'}),
            'mean_nrmse_pct': _num(float(d.table7.get('mean_nrmse_pct', math.nan)))},
        'remaining': dec.remaining if dec.verdict == 'inconclusive' else [],
        'would_separate': dec.separators,
        'notes': dec.notes,
        'groups': {g.name: [int(d.layout.markers[i]) for i in g.members] for g in d.layout.groups},
        'windows_s': d.layout.windows.tolist(),
        'markers_in_windows': markers_in_windows(d.layout),
        'headline': _finite(d.headline),
        'marker_problems': {str(k): v for k, v in d.problems.items()},
        'simulations': d.simulations,
        'wall_s': round(d.wall_s, 3),
    }
    out.update(extra or {})
    return out


def markers_in_windows(layout: Layout) -> dict[str, Any]:
    """Per marker, the windows its statistics count in, and why any is left out."""
    present = layout.presence()
    out: dict[str, Any] = {}
    for j, m in enumerate(layout.markers.tolist()):
        missing = [k for k in range(len(layout.windows)) if not present[j, k]]
        out[str(int(m))] = {
            'windows': [k for k in range(len(layout.windows)) if present[j, k]],
            'left_out': {f'w{k}': (f'not measured throughout {layout.windows[k, 0]:.2f}-'
                                   f'{layout.windows[k, 1]:.2f} s') for k in missing}}
    return out


def write_outputs(d: Diagnosis, out: Path, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """Write diagnosis.json, report.md, the plots and diagnosis.xlsx into ``out``."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        data = to_json(d, extra)
        (out / 'diagnosis.json').write_text(json.dumps(data, indent=2))
        from dempath_diagnose.report.diagnosis_plots import plot_all

        plots = plot_all(d, out)
        write_xlsx(d, data, out / 'diagnosis.xlsx')
        (out / 'report.md').write_text(markdown(d, data, plots))
    except OSError as err:
        raise OutputError(f'{out}: cannot write the diagnosis ({err})') from err
    return data


def markdown(d: Diagnosis, data: dict[str, Any], plots: list[str]) -> str:
    """report.md: plain sentences first, then the ranking, the remaining and the plots."""
    lines = [f'# Diagnosis: {data["verdict"]}', '']
    lines += [f'**Note:** {s}' for s in data.get('notes', [])] + [''] * bool(data.get('notes'))
    lines += [f'- {s}' for s in data['summary']] + ['']
    w = d.layout.windows
    lines += [f'The statistics cover the whole measured pass, {w[0, 0]:.2f}-{w[-1, 1]:.2f} s, '
              f'in {len(w)} windows, on {len(d.layout.markers)} markers.']
    lines += [f'- marker {m}: {", ".join(v["left_out"].values())}: left out of '
              f'{", ".join(v["left_out"])}; counted where measured'
              for m, v in data['markers_in_windows'].items() if v['left_out']]
    lines += [f'- marker {m}: left out ({why})' for m, why in data['marker_problems'].items()]
    if d.headline.get('value_mm') is not None:
        from dempath_diagnose.headline.stage import headline_sentence

        lines += ['', headline_sentence(d.headline, 'of the model as it is').capitalize() + '.']
    lines.append('')
    if data['remaining']:
        lines += ['Not ruled out: ' + ', '.join(data['remaining']) + '.', '']
    for s in data['would_separate']:
        lines.append(f'- would separate {s}')
    lines += ['', '| candidate | kind | probability | strength | explained | implausibility |',
              '|---|---|---|---|---|---|']
    b = data['baseline']
    lines.append(f'| nothing missing | baseline | {b["probability"]:.3f} | - | - | '
                 f'{b["implausibility"]:.1f} |')
    edges = []
    for r in data['ranking']:
        s = r['strength']
        mark = ' (at the range edge)' if s.get('at_range_edge') else ''
        lines.append(f'| {r["effect"]} | {r["kind"]} | {r["probability"]:.3f} | '
                      f'{s["value"]:.4g} +- {s["uncertainty"]:.2g} {s["unit"]}{mark} | '
                      f'{r["explained_fraction"]:.2f} | {r["implausibility"]:.1f} |')
        if mark and r['probability'] >= EDGE_NOTE_P:
            edges.append(f'- {r["effect"]}: the fit lies at the edge of the strengths searched '
                         f'({s["range"][0]:.4g}-{s["range"][1]:.4g} {s["unit"]}, the library\'s '
                         'span plus a quarter): the true strength may lie beyond, and its '
                         'uncertainty is larger than shown. A library run at a stronger '
                         'setting (`--strengths`) or a recalibration settles it.')
    lines += ['', *edges] if edges else []
    lines += adaptive_lines(data.get('adaptive'))
    t7 = d.table7
    if t7.get('markdown'):
        band = (f'your model run {t7["model"]}' if t7.get('model')
                else f'the model\'s {t7["model_runs"]} baseline runs')
        lines += ['', f'## Error before (the paper\'s Table 7: {band}, the {t7["top_n"]} best '
                  'Cube candidates per marker)', '', t7['markdown'].rstrip()]
    elif t7.get('error'):
        lines += ['', f'Table 7 could not be computed: {t7["error"]}']
    lines += ['', f'Simulations used: {data["simulations"]}; wall time {data["wall_s"]:.1f} s.',
              '']
    lines += [f'![{p}]({p})' for p in plots]
    return '\n'.join(lines) + '\n'


def adaptive_lines(adaptive: dict[str, Any] | None) -> list[str]:
    """report.md's section on the simulations run beyond the library (``--budget``): what was
    run and why, and how the probabilities moved."""
    if not adaptive:
        return []
    lines = ['', f'## Simulations beyond the library ({adaptive["extra_simulations"]} of a '
             f'budget of {adaptive["budget"]})', '',
             f'Verdict on the library alone: {adaptive["verdict_before"]}.', '']
    for k, step in enumerate(adaptive['steps'], 1):
        for run in step['runs']:
            lines.append(f'{k}. {run["candidate"]} at {run["strength"]:.4g} '
                         f'({run["why"].replace("_", " ")}): {run["reason"]}.')
        moved = ', '.join(f'{name} {step["before"].get(name, 0.0):.2f} -> {p:.2f}'
                          for name, p in step['after'].items()
                          if max(p, step['before'].get(name, 0.0)) >= 0.05)
        lines.append(f'   {step["simulations"]} runs; verdict {step["verdict_before"]} -> '
                     f'{step["verdict_after"]}; probabilities {moved}.')
    lines += ['', f'Stopped: {adaptive["stop"]}.']
    return lines


def write_xlsx(d: Diagnosis, data: dict[str, Any], path: Path) -> None:
    """Ranking, statistics and per-marker errors as three sheets."""
    from openpyxl import Workbook

    wb = Workbook()
    ws = wb.active
    ws.title = 'ranking'
    ws.append(['effect', 'kind', 'probability', 'strength', 'sd', 'unit', 'explained',
               'implausibility'])
    for r in data['ranking']:
        s = r['strength']
        ws.append([r['effect'], r['kind'], r['probability'], s['value'], s['uncertainty'],
                   s['unit'], r['explained_fraction'], r['implausibility']])
    st = wb.create_sheet('statistics')
    st.append(['statistic', 'measured', 'model', 'difference', 'z (seed spread)'])
    for name, v in data['error_before']['statistics'].items():
        st.append([name, v['measured'], v['model'], v['difference'], v['z']])
    mk = wb.create_sheet('markers')
    mk.append(['marker', *[f'rms error {a} [m]' for a in AXES]])
    for m, v in data['error_before']['markers'].items():
        mk.append([int(m), *[v[a] for a in AXES]])
    t7 = wb.create_sheet('table7')
    t7.append(['marker', 'N', 'MAE [m]', 'MAE sd [m]', 'RMSE [m]', 'RMSE sd [m]', 'range [m]',
               'nRMSE [%]'])
    for r in data['error_before']['table7'].get('rows', []):
        t7.append([r['marker'], r['n_best'], r['mae_m'], r['mae_sd_m'], r['rmse_m'],
                   r['rmse_sd_m'], r['range_m'], r['nrmse_pct']])
    wb.save(path)


def print_ranking(data: dict[str, Any], console: Any = None) -> None:
    """The ranking as a rich table on the terminal (or on ``console``)."""
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f'diagnosis: {data["verdict"]}')
    for col in ('candidate', 'kind', 'probability', 'strength', 'explained', 'implausibility'):
        table.add_column(col)
    b = data['baseline']
    table.add_row('nothing missing', 'baseline', f'{b["probability"]:.3f}', '-', '-',
                  f'{b["implausibility"]:.1f}')
    for r in data['ranking']:
        s = r['strength']
        edge = ' (range edge)' if s.get('at_range_edge') else ''
        table.add_row(r['effect'], r['kind'], f'{r["probability"]:.3f}',
                      f'{s["value"]:.4g} +- {s["uncertainty"]:.2g} {s["unit"]}{edge}',
                      f'{r["explained_fraction"]:.2f}', f'{r["implausibility"]:.1f}')
    console = console or Console()
    console.print(table)
    for s in data.get('notes', []):
        console.print(f'note: {s}')
    for s in data['summary']:
        console.print(s)


def ranking_text(data: dict[str, Any], width: int = 80) -> str:
    """:func:`print_ranking` as plain text ``width`` columns wide (for the demo's stage lines)."""
    import io

    from rich.console import Console

    buffer = io.StringIO()
    print_ranking(data, Console(file=buffer, width=width))
    return buffer.getvalue()
