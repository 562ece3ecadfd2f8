"""The demo's report: one HTML page with its PNGs beside it (``<out>/report/index.html``).

Written for a colleague: what was measured and how well the cameras were calibrated, what the
detector saw, how the model's trajectories compare with the measured ones before and after the
recalibration (figures and the paper's Table 7), where the model fails (the error map), which
effect the diagnosis names and with what probability, and how the error fell per iteration.
Stages that did not run (no signature library) say so in their section. Every value is
escaped; the page loads nothing from the network.
"""

from __future__ import annotations

import html
import shutil
import time
from pathlib import Path
from typing import Any

from dempath_bringup.context import DemoContext, need

STYLE = """body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;
color:#222}h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;margin:.6em 0}td,th{border:1px solid #bbb;padding:.25em .6em;
text-align:right}th{background:#eee}td:first-child{text-align:left}img{max-width:100%;
border:1px solid #ddd}.missing{background:#fff3cd;border:1px solid #e0c060;padding:.6em}
.cols{display:flex;gap:1.5em;flex-wrap:wrap}code{background:#f4f4f4;padding:0 .2em}"""


def _e(value: Any) -> str:
    return html.escape(str(value))


def _table(header: list[str], rows: list[list[Any]]) -> str:
    head = ''.join(f'<th>{_e(h)}</th>' for h in header)
    body = ''.join('<tr>' + ''.join(f'<td>{_e(c)}</td>' for c in r) + '</tr>' for r in rows)
    return f'<table><tr>{head}</tr>{body}</table>'


def _img(name: str | None, alt: str) -> str:
    if name is None:
        return f'<p class="missing">{_e(alt)}: not available in this run.</p>'
    return f'<p><img src="{_e(name)}" alt="{_e(alt)}"></p>'


def _table7(table: Any) -> str:
    rows = [[r.marker, f'{r.mae_mean * 1e3:.2f}', f'{r.rmse_mean * 1e3:.2f}',
             f'{r.range_m * 1e3:.1f}', f'{r.nrmse:.2f}'] for r in table.rows]
    means = ', '.join(f'{k}: {v:.2f} %' for k, v in table.mean_nrmse.items())
    return (_table(['marker', 'MAE [mm]', 'RMSE [mm]', 'range [mm]', 'nRMSE [%]'], rows)
            + f'<p>mean nRMSE {_e(means)} (the paper: 4.7 % at 1 m/s)</p>')


def _calibration(ctx: DemoContext) -> str:
    calibration = need(ctx.calibration, 'calibration')
    rep = calibration.result.report
    rows = [[c, f"{rep['rmse_px'][c]:.3f}", rep['views'][c]] for c in ('side', 'front')]
    html_ = _table(['camera', 'reprojection RMSE [px]', 'views'], rows)
    spacing = rep.get('corner_spacing', {})
    if spacing:
        html_ += (f"<p>Neighbouring-corner distance {spacing['mean_mm']:.3f} mm for 40.4 mm "
                  'squares (the paper: 40.43 mm).</p>')
    checks = calibration.truth
    if checks:
        html_ += "<p>Against the synthetic recording's true cameras:</p>" + _table(
            ['camera', 'fx [%]', 'fy [%]', 'cx [px]', 'cy [px]', 'centre [mm]', 'angle [deg]'],
            [[c['camera'], f"{c['fx_pct']:+.3f}", f"{c['fy_pct']:+.3f}", f"{c['cx_px']:+.2f}",
              f"{c['cy_px']:+.2f}", f"{c['centre_mm']:.2f}", f"{c['angle_deg']:.3f}"]
             for c in checks])
    return html_


def _diagnosis(ctx: DemoContext, figs: dict[str, str | None]) -> str:
    stage = ctx.diagnosis
    if stage is None or stage.outcome is None:
        missing = stage.missing if stage is not None else 'no diagnosis'
        return (f'<p class="missing">Not run: {_e(missing)}. '
                "The diagnosis needs the scene's signature library.</p>")
    data = stage.outcome.data
    rank = list(data['ranking']) + ([data['baseline']] if data.get('baseline') else [])
    rank.sort(key=lambda x: -x['probability'])
    rows = [[('nothing missing (the current model)' if x['kind'] == 'baseline' else x['effect']),
             f"{x['probability']:.3f}", _strength(x), f"{x.get('implausibility', 0):.2f}",
             'yes' if x.get('ruled_out') else 'no'] for x in rank]
    summary = data.get('summary') or []
    text = ' '.join(summary) if isinstance(summary, list) else str(summary)
    return (f"<p>Verdict: <b>{_e(data['verdict'])}</b>. {_e(text)}</p>"
            + _table(['candidate', 'probability', 'fitted strength', 'implausibility',
                      'ruled out'], rows)
            + '<h3>Group statistics against the model band (whole pass)</h3>'
            + _img(figs.get('statistics'), 'group statistics against the model band')
            + '<h3>Error map</h3>' + _img(figs.get('error_map'), 'error map'))


def _strength(x: dict[str, Any]) -> str:
    s = x.get('strength') or {}
    if s.get('value') is None:
        return '-'
    return f"{s['parameter']} {s['value']:.4g} +- {s['uncertainty']:.2g} {s['unit']}"


def _recalibration(ctx: DemoContext, figs: dict[str, str | None]) -> str:
    if ctx.recalibration is None:
        return '<p class="missing">Not run: there is no diagnosis to recalibrate from.</p>'
    data = ctx.recalibration.data
    s = data['strength']
    what = (f"{data['effect']}.{data['parameter']}: {s['before']:.4g} -> {s['value']:.4g} "
            f"{s['unit']} (+- {s['uncertainty']:.2g})" if data['changed'] else 'nothing changed')
    return (f"<p>{_e(what)}; stopped: {_e(data['stop_reason'])} ({data['simulations']} "
            'simulations).</p>' + _errors_table(ctx, data)
            + '<p>The floor is what the true model itself gives over packing seeds: a fall is '
            'judged against it, not against zero (docs/recalibration.md).</p>'
            + _img(figs.get('headline'), 'the headline error before and after, each beside '
                   'its own floor band (the model played as the measurement, like for like)')
            + _img(figs.get('headline_iterations'), 'the headline error per iteration, each '
                   'beside its own floor band')
            + _img(figs.get('iterations'), 'error against iteration')
            + _img(figs.get('recal_trajectories'),
                   "the model's band before and after on the library's seeds"))


def _errors_table(ctx: DemoContext, data: dict[str, Any]) -> str:
    """Each error before and after the recalibration, beside its own like-for-like floor where
    one was computed (a floor computed another way is not printed beside a figure)."""
    bands = data.get('floor_bands') or []

    def d2band(iteration0: bool) -> str:
        b = next((b for b in (bands if iteration0 else bands[::-1])
                  if (b['iteration'] == 0) == iteration0), None)
        return '-' if b is None else f"{max(b['low'], 0.0):.1f}-{b['high']:.1f}"

    rows = [["d<sup>2</sup> of the diagnosis' group statistics", f"{data['error_before']:.1f}",
             f"{data['error_after']:.1f}", d2band(True), d2band(False)]]
    paper = data.get('paper')
    if paper:
        pb, pa = paper['before'], paper['after']

        def band(fl: dict[str, Any] | None) -> str:
            if not fl:
                return '-'
            return f"{fl['mean_nrmse_pct']:.2f} +- {fl['mean_nrmse_sd_pct']:.2f}"

        pools = paper.get('pool_seeds')
        rows.append([f"mean nRMSE [%], the library's seeds (pools of {pools})",
                     f"{pb['mean_nrmse_pct']:.2f}", f"{pa['mean_nrmse_pct']:.2f}",
                     band(paper['floor']), band(paper.get('floor_after'))])
        rows += headline_rows(paper)
    after = ctx.after.table7 if ctx.after is not None else None
    for speed, value in need(ctx.comparison, 'comparison').table7.mean_nrmse.items():
        new = after.mean_nrmse.get(speed) if after is not None else None
        rows.append([f'mean nRMSE [%], this recording ({speed})', f'{value:.2f}',
                     '-' if new is None else f'{new:.2f}', '-', '-'])
    head = ''.join(f'<th>{h}</th>' for h in ('error', 'before', 'after', 'floor before',
                                             'floor after'))
    body = ''.join('<tr>' + ''.join(f'<td>{c if i == 0 else _e(c)}</td>'
                                    for i, c in enumerate(row)) + '</tr>' for row in rows)
    reduction = 100 * (data.get('error_reduction') or 0.0)
    stop = ('The recalibration stops when d<sup>2</sup> enters the like-for-like band of the '
            'model at the best strengths so far (each library seed playing the measurement with '
            "the diagnosis' markers, samples, layout and covariance)." if bands else
            'No like-for-like d<sup>2</sup> band could be computed here (more than one strength '
            'fitted): the recalibration stopped at the nominal chi<sup>2</sup> mean k = '
            f"{data['floor']['k']:g}, by which {reduction:.0f} % of the error above it was "
            'removed.')
    return (f'<table><tr>{head}</tr>{body}</table>{table7_reading(paper)}'
            '<p>Each floor is its own model played as the '
            'measurement with the same markers, samples, noise and pool size (the model before: '
            f"the library's baseline; after: the fitted model). {stop} The held-out markers "
            'were left out of the diagnosis and the fit: their fall checks the fit on data it '
            "did not see. The recording's own Table 7 is not printed beside a floor: its "
            "candidate pool is not the floor's.</p>")


def table7_reading(paper: dict[str, Any] | None) -> str:
    """What the paper's metric can and cannot show here, said from the measured figures.

    Table 7's nRMSE takes the best 10 particles of each marker's Cube: a model whose paths vary
    more from seed to seed gets a better best-10, so its floor (the model played as the
    measurement) moves with the model. When the fitted model's own floor is higher than the
    model before's, Table 7 cannot show the effect being added, whatever the error did.
    """
    if not paper or not paper.get('floor') or not paper.get('floor_after'):
        return ''
    before, after = paper['before']['mean_nrmse_pct'], paper['after']['mean_nrmse_pct']
    fb, fa = paper['floor'], paper['floor_after']
    f_before, f_after, sd_after = (fb['mean_nrmse_pct'], fa['mean_nrmse_pct'],
                                   fa['mean_nrmse_sd_pct'])
    inside = abs(after - f_after) <= 2.0 * max(sd_after, 1e-9)
    if f_after <= f_before + 2.0 * max(fb['mean_nrmse_sd_pct'], sd_after):
        verdict = (f"The paper's Table 7 mean nRMSE went from {before:.2f} to {after:.2f} % "
                   f"against floors of {f_before:.2f} and {f_after:.2f} %: here it can be "
                   'read beside the headline error.')
    else:
        verdict = (f"<b>The paper's Table 7 cannot show this fall.</b> Its mean nRMSE went from "
                   f'{before:.2f} to {after:.2f} %, but its floor moved with the model: '
                   f'{f_before:.2f} % for the model before, {f_after:.2f} +- {sd_after:.2f} % '
                   'for the fitted model played as its own measurement. Best-10-of-the-Cube '
                   'nRMSE rewards a model whose paths vary more from seed to seed, and the '
                   'fitted model varies more, so even the true model scores worse on it. The '
                   f"after figure {'lies inside' if inside else 'lies outside'} the fitted "
                   "model's own Table 7 floor; the fall is shown by the headline error and "
                   'd<sup>2</sup>, which do not reward a wider model.')
    return f'<p>{verdict}</p>'


def headline_rows(paper: dict[str, Any]) -> list[list[str]]:
    """Rows of the headline error before and after, each beside its own floor band: on the
    markers the diagnosis and the fit used, and on the held-out markers (left out of both:
    the held-out check of the fit)."""
    def cell(entry: dict[str, Any] | None) -> tuple[str, str]:
        if not entry or entry.get('value_mm') is None:
            return '-', '-'
        f = entry['floor_mm']
        return f"{entry['value_mm']:.2f} ({entry['place']})", f"{f['low']:.2f}-{f['high']:.2f}"

    rows = []
    for key, what in (('headline', 'headline error [mm], the markers fitted'),
                      ('headline_held_out', 'headline error [mm], held-out markers')):
        entry = paper.get(key)
        if not entry:
            continue
        if key == 'headline_held_out':
            what += f" {', '.join(map(str, entry['markers']))} (not fitted)"
        (b, fb), (a, fa) = cell(entry.get('before')), cell(entry.get('after'))
        rows.append([what, b, a, fb, fa])
    return rows


def write_report(ctx: DemoContext, figs: dict[str, str | None], folder: Path,
                 meta: dict[str, Any]) -> Path:
    """Write ``folder/index.html`` of the stages' results (the figures are already in
    ``folder``)."""
    after = ctx.after.table7 if ctx.after is not None else None
    before = need(ctx.comparison, 'comparison').table7
    parts = [f'<h1>dempath: {_e(meta["title"])}</h1>',
             f'<p>{_e(meta["what"])}<br>Made {_e(time.strftime("%Y-%m-%d %H:%M:%S"))}; stages: '
             + ', '.join(f'{_e(k)} {v:.1f} s' for k, v in meta.get('stages', {}).items())
             + '.</p>',
             '<h2>1. Calibration</h2>', _calibration(ctx),
             _img(figs.get('calibration'), 'calibration figures'),
             '<h2>2. Detection</h2>', f"<p>{_e(meta.get('detection', ''))}</p>",
             _img(figs.get('detections'), 'a frame with the detections drawn'),
             _img(figs.get('coverage'), 'which markers were reconstructed in 3D, and when'),
             '<h2>3. Measured against the model</h2>',
             _img(figs.get('trajectories'), 'measured vs model trajectories (XZ, YZ)'),
             '<div class="cols"><div><h3>Table 7, before</h3>' + _table7(before)
             + '</div><div><h3>Table 7, after the recalibration</h3>'
             + (_table7(after) if after is not None else
                '<p class="missing">No recalibrated model in this run.</p>') + '</div></div>',
             '<h2>4. Diagnosis</h2>', _diagnosis(ctx, figs),
             '<h2>5. Recalibration</h2>', _recalibration(ctx, figs),
             '<h2>Files</h2><ul>' + ''.join(f'<li><code>{_e(k)}</code>: {_e(v)}</li>'
                                            for k, v in meta.get('files', {}).items()) + '</ul>']
    page = (f'<!doctype html><html lang="en"><head><meta charset="utf-8"><title>dempath demo '
            f'report</title><style>{STYLE}</style></head><body>{"".join(parts)}</body></html>')
    path = folder / 'index.html'
    tmp = path.with_suffix('.tmp')
    tmp.write_text(page)
    tmp.replace(path)
    return path


def copy_figure(src: Path, folder: Path, name: str) -> str | None:
    """Copy a PNG another stage wrote into the report folder; its file name, or None."""
    if not src.is_file():
        return None
    shutil.copyfile(src, folder / name)
    return name
