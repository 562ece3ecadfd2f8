"""Figures and report of ``dempath recalibrate``: the error falling, and the paths before/after.

- ``recalibration.png``: the error d^2 per iteration (real runs, and what the emulator expected)
  over the floor band (the central 95 % of chi^2_k: what the true model gives over packing
  seeds), with one panel per fitted strength below it.
- ``trajectories.png``: the measured markers' displacement over time (X lateral, Y vertical,
  Z travel) with the model's band (10-90 % of the cube candidates over the evaluation's seeds)
  before and after, for the markers the model missed most.
- ``recalibration.md``: what changed, the error before/after beside the floor on the diagnosis'
  statistics and on the paper's metrics (Table 7 before and after), and the two figures.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dempath_diagnose.decision.statistics import Layout
from dempath_diagnose.library.counterparts import cube_members
from dempath_diagnose.recalibration.loop import Recalibration
from dempath_diagnose.records import F64, Measurement, PassRecord

MAX_MARKERS = 4  # markers shown in trajectories.png (those the model missed most)
BAND = (10.0, 90.0)  # percentiles of the model band


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    return plt


def plot_steps(r: Recalibration, path: Path) -> str:
    """Error vs iteration with the floor band, each fitted strength below."""
    from matplotlib.ticker import MaxNLocator
    from scipy import stats

    plt = _pyplot()
    it = [s.iteration for s in r.steps]
    err = [s.error if np.isfinite(s.error) else np.nan for s in r.steps]
    n = len(r.params)
    fig, axes = plt.subplots(1 + n, 1, sharex=True, figsize=(6, 3 + 1.6 * n),
                             gridspec_kw={'height_ratios': [2] + [1] * n})
    a = axes[0]
    a.plot(it, err, 'o-', label='error d$^2$ (real runs)')
    a.plot(it, [s.emulated for s in r.steps], 'x--', label='emulated')
    failed = [s.iteration for s in r.steps if not np.isfinite(s.error)]
    if failed:
        a.plot(failed, [r.before] * len(failed), 'rv', label='failed (unstable) run')
    k = r.floor.k
    a.axhspan(stats.chi2.ppf(0.025, k), stats.chi2.ppf(0.975, k), color='0.85',
              label='floor: true model over seeds (95 %)')
    a.axhline(k, color='0.5', lw=0.8)
    a.set_yscale('log')
    a.set_ylabel('d$^2$')
    a.set_title(f'recalibration of {r.effect}: {r.stop}')
    a.legend(fontsize=7)
    for i, p in enumerate(r.params):
        b = axes[1 + i]
        b.plot(it, [s.strengths[i] for s in r.steps], 'o-')
        if r.changed and p.sd > 0:
            b.axhspan(p.value - p.sd, p.value + p.sd, color='C2', alpha=0.2,
                      label='fitted +- 1 sd')
            b.legend(fontsize=7)
        b.set_ylabel(f'{p.name}.{p.parameter}\n[{p.unit}]', fontsize=8)
    axes[-1].set_xlabel('iteration')
    axes[-1].xaxis.set_major_locator(MaxNLocator(integer=True))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path.name


def _cube_paths(records: Sequence[PassRecord], layout: Layout,
                cube: tuple[float, float, float], j: int, times: F64) -> F64:
    """(p, nt, 3) displacements [m] of marker j's cube candidates over runs, on ``times``."""
    out = []
    for rec in records:
        (idx,) = cube_members(rec.start, layout.starts[j:j + 1], cube)
        d = rec.positions[:, idx].astype(np.float64) - rec.start[idx][None]
        for q in range(len(idx)):
            out.append(np.stack([np.interp(times, rec.times, d[:, q, a]) for a in range(3)], 1))
    return np.array(out) if out else np.full((1, len(times), 3), np.nan)


def plot_trajectories(meas: Measurement, layout: Layout, cube: tuple[float, float, float],
                      before: Sequence[PassRecord], after: Sequence[PassRecord],
                      path: Path) -> str:
    """Measured markers with the model band before and after (see the module docstring)."""
    plt = _pyplot()
    t = meas.times
    worst = _worst_markers(meas, layout, cube, before)
    fig, axes = plt.subplots(len(worst), 3, sharex=True, figsize=(10, 2.2 * len(worst)),
                             squeeze=False)
    for row, j in enumerate(worst):
        d = meas.positions[:, j] - layout.starts[j]
        for label, recs, color in (('model before', before, '0.6'),
                                   ('model after', after, 'C2')):
            if not recs:
                continue
            lo, hi = np.nanpercentile(_cube_paths(recs, layout, cube, j, t), BAND, axis=0)
            for a in range(3):
                axes[row, a].fill_between(t, lo[:, a] * 1e3, hi[:, a] * 1e3, color=color,
                                          alpha=0.35, label=label, lw=0)
        for a, name in enumerate(('X lateral', 'Y vertical', 'Z travel')):
            axes[row, a].plot(t, d[:, a] * 1e3, 'k-', lw=1.2, label='measured')
            axes[row, a].set_title(f'marker {layout.markers[j]}: {name}', fontsize=8)
            axes[row, a].set_ylabel('mm', fontsize=8)
    axes[0, 0].legend(fontsize=7)
    for a in range(3):
        axes[-1, a].set_xlabel('t [s]')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name


def _worst_markers(meas: Measurement, layout: Layout, cube: tuple[float, float, float],
                   before: Sequence[PassRecord]) -> list[int]:
    """Indices of the markers farthest (RMS over time) from the model's median before."""
    t = meas.times
    err = []
    for j in range(len(layout.markers)):
        d = meas.positions[:, j] - layout.starts[j]
        med = np.nanmedian(_cube_paths(before, layout, cube, j, t), axis=0)
        e = np.nanmean((d - med) ** 2) if np.isfinite(d).any() else -1.0
        err.append(float(e) if np.isfinite(e) else -1.0)
    return [int(j) for j in np.argsort(err)[::-1][:MAX_MARKERS]]


def markdown(data: dict[str, Any], figures: Sequence[str]) -> str:
    """recalibration.md: what changed, error before/after beside the floor, Table 7, figures."""
    lines = [f'# Recalibration: {data["effect"]}', '', f'Stopped: {data["stop_reason"]}.', '']
    for p in data['parameters']:
        lines.append(f'- {p["name"]}.{p["parameter"]}: {p["before"]:g} -> {p["value"]:.6g} +- '
                     f'{p["uncertainty"]:.2g} {p["unit"]}')
    f = data['floor']
    lines += [f'- error d^2 (diagnosis statistics): {data["error_before"]:.1f} -> '
              f'{data["error_after"]:.1f}; floor {f["k"]} (95 % band {f["low"]:.1f}-'
              f'{f["high"]:.1f}, significant above {f["significant"]:.1f}); '
              f'{100 * data["error_reduction"]:.0f} % of the error above the floor removed',
              f'- simulations: {data["simulations"]} ({data["failures"]} failed candidates)']
    paper = data.get('paper')
    if paper:
        fl = paper['floor']
        lines += [f'- mean nRMSE (paper, Table 7): {paper["before"]["mean_nrmse_pct"]:.2f} % -> '
                  f'{paper["after"]["mean_nrmse_pct"]:.2f} %; floor (true model over '
                  f'{fl["seeds"]} packing seeds) {fl["mean_nrmse_pct"]:.2f} +- '
                  f'{fl["mean_nrmse_sd_pct"]:.2f} %', '',
                  '## Table 7 before', '', paper['table7_before_md'],
                  '## Table 7 after', '', paper['table7_after_md']]
    tried = data.get('tried', {})
    if len(tried) > 1:
        lines += ['## Candidates tried', '', '| candidate | error d^2 after | removed |',
                  '| --- | ---: | ---: |']
        lines += [f'| {k} | {v["error_after"]:.1f} | {100 * v["reduction"]:.0f} % |'
                  for k, v in tried.items()]
        lines.append('')
    lines += [f'![{name}]({name})' for name in figures]
    return '\n'.join(lines) + '\n'
