"""The validation report: run every case on dempath (and LIGGGHTS when present), write
``report.md``, ``report.json`` and PNG plots.

Sections: two-sphere impact over a range of speeds and restitutions, a sphere on an incline
(rest / roll / slide), energy drift in an elastic box, the angle of repose of a lifted-cylinder
discharge beside the paper's figures, and optionally the cross-engine comparison of a scene.
"""

from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dempath_sim.validation import CASES, energy_conservation, impact, incline, pile, repose
from dempath_sim.validation.cross_engine import CrossEngineReport

logger = logging.getLogger(__name__)

SPEEDS = (0.1, 0.3, 1.0, 3.0)
RESTITUTIONS = (1.0, 0.7, 0.3)
INCLINES = ((10.0, 0.26), (14.0, 0.26), (16.0, 0.26), (20.0, 0.26), (30.0, 0.26),
            (20.0, 0.0), (40.0, 0.0), (60.0, 0.0))


@dataclass
class Report:
    """Collected results; ``figures`` holds the numbers written to report.json."""

    out: Path
    liggghts: bool
    figures: dict[str, Any]
    lines: list[str]


def _impact(rep: Report) -> None:
    import matplotlib.pyplot as plt

    rows, fig, axes = [], *plt.subplots(1, 2, figsize=(10, 4))
    for e in RESTITUTIONS:
        for v in SPEEDS:
            case = impact.ImpactCase(v, e)
            res = [impact.impact_dempath(case)]
            if rep.liggghts:
                res.append(impact.impact_liggghts(case, rep.out / 'work' / f'impact-{v}-{e}'))
            rows += [(r.engine, v, e, r.duration, r.reference_duration, r.duration_error,
                      r.restitution, r.restitution_error) for r in res]
        for eng, mark in (('dempath', 'o'), ('liggghts', 'x')):
            pts = [r for r in rows if r[0] == eng and r[2] == e]
            if pts:
                axes[0].plot([p[1] for p in pts], [p[3] * 1e3 for p in pts], mark,
                             label=f'{eng} e={e}')
                axes[1].plot([p[1] for p in pts], [p[6] for p in pts], mark)
        ref = [r for r in rows if r[0] == 'dempath' and r[2] == e]
        axes[0].plot([p[1] for p in ref], [p[4] * 1e3 for p in ref], '-', lw=0.8)
        axes[1].axhline(e, lw=0.8)
    axes[0].set(xscale='log', xlabel='impact speed [m/s]', ylabel='contact duration [ms]')
    axes[1].set(xscale='log', xlabel='impact speed [m/s]', ylabel='restitution [-]')
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(rep.out / 'impact.png', dpi=110)
    plt.close(fig)
    worst_t = max(r[5] for r in rows)
    worst_e = max(r[7] for r in rows)
    rep.figures['impact'] = {'worst_duration_error': worst_t, 'worst_restitution_error': worst_e,
                             'runs': len(rows)}
    rep.lines += ['## Two-sphere normal impact', '',
                  'Spheres of 4 mm, E = 1.7 MPa, nu = 0.25, 1734 kg/m^3; reference: analytic '
                  'Hertz duration (e = 1) or the damped Hertz ODE (e < 1), restitution = set e.',
                  '', '| engine | v [m/s] | e | duration [ms] | reference [ms] | error | '
                  'measured e | error |', '|---|---|---|---|---|---|---|---|']
    rep.lines += [f'| {r[0]} | {r[1]} | {r[2]} | {r[3] * 1e3:.4f} | {r[4] * 1e3:.4f} | '
                  f'{100 * r[5]:.3f} % | {r[6]:.4f} | {100 * r[7]:.3f} % |' for r in rows]
    rep.lines += ['', f'Worst duration error {100 * worst_t:.3f} %, worst restitution error '
                  f'{100 * worst_e:.3f} % (bar: 2 %).', '', '![impact](impact.png)', '']


def _incline(rep: Report) -> None:
    import matplotlib.pyplot as plt

    rows = []
    for angle, mur in INCLINES:
        case = incline.InclineCase(angle, rolling=mur)
        res = [incline.incline_dempath(case)]
        if rep.liggghts:
            res.append(incline.incline_liggghts(case, rep.out / 'work' / f'incline-{angle}-{mur}',
                                                8.5e-5))
        rows += [(r.engine, angle, mur, case.regime(), case.analytic_acceleration(),
                  r.acceleration, r.error) for r in res]
    fig, ax = plt.subplots(figsize=(6, 4))
    for mur in (0.0, 0.26):
        th = np.linspace(1, 65, 200)
        ax.plot(th, [incline.InclineCase(t, rolling=mur).analytic_acceleration() for t in th],
                lw=0.8, label=f'analytic mu_r={mur}')
        for eng, mark in (('dempath', 'o'), ('liggghts', 'x')):
            pts = [r for r in rows if r[0] == eng and r[2] == mur]
            ax.plot([p[1] for p in pts], [p[5] for p in pts], mark, label=f'{eng} mu_r={mur}')
    ax.set(xlabel='incline angle [deg]', ylabel='acceleration [m/s^2]')
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(rep.out / 'incline.png', dpi=110)
    plt.close(fig)
    rep.figures['incline'] = {'worst_error_g': max(r[6] for r in rows),
                              'rolling_onset_deg': math.degrees(math.atan(0.26))}
    rep.lines += ['## Sphere on an incline', '', 'Steel plane, mu = 0.40, mu_r = 0 or 0.26 '
                  '(EPSD2). Onsets: rolling at atan(mu_r) = '
                  f'{math.degrees(math.atan(0.26)):.2f} deg, sliding at atan(3.5 mu - 2.5 mu_r).',
                  '', '| engine | angle [deg] | mu_r | regime | analytic a | measured a | '
                  'error / g |', '|---|---|---|---|---|---|---|']
    rep.lines += [f'| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]:.4f} | {r[5]:.4f} | '
                  f'{r[6]:.2e} |' for r in rows]
    rep.lines += ['', '![incline](incline.png)', '']


def _energy(rep: Report) -> None:
    case = energy_conservation.EnergyCase()
    res = [energy_conservation.energy_dempath(case)]
    if rep.liggghts:
        res.append(energy_conservation.energy_liggghts(case, rep.out / 'work' / 'energy',
                                                       res[0].dt))
    rep.figures['energy'] = {r.engine: r.drift for r in res}
    rep.lines += ['## Energy', '', f'{case.n_side ** 3} elastic frictionless spheres in a '
                  f'closed box, no gravity, {case.steps} steps; kinetic + Hertz elastic energy.',
                  '', '| engine | dt [s] | drift |', '|---|---|---|']
    rep.lines += [f'| {r.engine} | {r.dt:.3e} | {100 * r.drift:.3f} % |' for r in res]
    rep.lines += ['', 'Bar: < 1 %.', '']


def _repose_runs(rep: Report, cases: list[repose.ReposeCase]) -> list[pile.ReposeResult]:
    """Run every seed's case on dempath and (when present) LIGGGHTS; per-run rows (with the
    wall time) go to ``rep.figures['repose_runs']``."""
    from dempath_sim.engine.timestep import rayleigh_time_step

    res, rows = [], []
    for case in cases:
        _, radii = case.particles()
        dt = case.params().rayleigh_safety * rayleigh_time_step(
            radii, np.zeros(len(radii), np.int32), case.params())
        for eng in ('dempath', 'liggghts') if rep.liggghts else ('dempath',):
            t0 = time.perf_counter()
            r = (repose.repose_dempath(case) if eng == 'dempath' else repose.repose_liggghts(
                case, rep.out / 'work' / f'repose-{case.seed}', dt))
            res.append(r)
            rows.append({'engine': r.engine, 'seed': case.seed, 'spheres': len(radii),
                         'base_deg': r.base_deg, 'top_deg': r.top_deg, 'cone_deg': r.cone_deg,
                         'view_deg': list(r.view_deg), 'band_deg': r.band_deg.tolist(),
                         'height_m': r.height, 'sim_time_s': r.sim_time,
                         'wall_s': time.perf_counter() - t0})
    rep.figures['repose_runs'] = rows
    return res


def plot_repose(res: list[pile.ReposeResult], path: Path, title: str = '',
                labels: list[str] | None = None) -> None:
    """Radial surface profiles h(r) of the piles, with the paper's 30.82 deg slope for scale."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.5))
    for k, r in enumerate(res):
        name = r.engine if labels is None else labels[k]
        ax.plot(r.r * 1e3, r.h * 1e3, '.-', lw=0.8, label=f'{name}: base {r.base_deg:.1f}, '
                f'top {r.top_deg:.1f} deg')
    first = res[0]
    foot = float(first.r[np.flatnonzero(first.h >= 0.1 * first.height).max()]) * 1e3
    run = first.height * 1e3 / math.tan(math.radians(30.82))
    ax.plot([foot - run, foot], [first.height * 1e3, 0.0], 'k--', lw=0.8,
            label='30.82 deg (paper, experiment) through the foot')
    ax.set(xlabel='radius [mm]', ylabel='pile surface height [mm]', aspect='equal',
           title=title)
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _repose(rep: Report, cases: list[repose.ReposeCase], preset: str,
            overrides: dict[str, float] | None = None) -> None:
    res = _repose_runs(rep, cases)
    plot_repose(res, rep.out / 'repose.png')
    summary = pile.summarise(res)
    rep.figures['repose'] = {'preset': preset, 'overrides': overrides or {},
                             'seeds': [c.seed for c in cases], **summary}
    exp, rocky, case = repose.PAPER_EXPERIMENT_DEG, repose.PAPER_ROCKY_DEG, cases[0]
    n = len(case.particles()[1])
    rep.lines += ['## Angle of repose (lifted cylinder, Table 6 parameters)', '',
                  f'Set-up `{preset}` (overrides {overrides or {}}): cylinder '
                  f'{case.diameter * 1e3:.0f} mm, {n} spheres of '
                  f'{case.particle_diameter * 1e3:.0f} mm +-{100 * case.spread:.0f} %, lift '
                  f'{case.lift_speed} m/s, seeds {[c.seed for c in cases]}. Angles from the '
                  'base / top are flank fits at 10-60 % / 40-90 % of the pile height; cone = '
                  'line from the apex to the foot (see docs/validation_repose.md).', '',
                  '| source | seed | from the base [deg] | from the top [deg] | cone [deg] | '
                  'silhouette base / top [deg] |', '|---|---|---|---|---|---|',
                  f'| paper, experiment | | {exp[0]} | {exp[1]} | | |',
                  f'| paper, Rocky model | | {rocky[0]} | {rocky[1]} | | |']
    seeds = [c.seed for c in cases for _ in range(len(res) // len(cases))]
    rep.lines += [f'| {r.engine} | {k} | {r.base_deg:.2f} | {r.top_deg:.2f} | '
                  f'{r.cone_deg:.2f} | {r.view_deg[0]:.2f} / {r.view_deg[1]:.2f} |'
                  for r, k in zip(res, seeds, strict=True)]
    rep.lines += [f'| {eng}, mean +- sd | | {s["base_deg"][0]:.2f} +- {s["base_deg"][1]:.2f} | '
                  f'{s["top_deg"][0]:.2f} +- {s["top_deg"][1]:.2f} | '
                  f'{s["cone_deg"][0]:.2f} +- {s["cone_deg"][1]:.2f} | |'
                  for eng, s in summary.items()]
    rep.lines += ['', '![repose](repose.png)', '']


def cross_engine_section(rep: Report, cross: CrossEngineReport, scene_name: str) -> None:
    """Add the cross-engine table and plot."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.5))
    for stats, colour, name in ((cross.dempath, 'C0', 'dempath'),
                                (cross.liggghts, 'C1', 'liggghts')):
        for k, s in enumerate(stats):
            lab = name if k == 0 else None
            axes[0].plot(s.times, s.axis * 1e3, color=colour, lw=0.8, label=lab)
            axes[1].plot(s.times, s.lateral * 1e3, color=colour, lw=0.8, label=lab)
    axes[0].set(xlabel='t [s]', ylabel='axis markers mean displacement [mm]')
    axes[1].set(xlabel='t [s]', ylabel='lateral markers mean displacement [mm]')
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(rep.out / 'cross_engine.png', dpi=110)
    plt.close(fig)
    rep.figures['cross_engine'] = cross.summary()
    rep.lines += [f'## Cross-engine ({scene_name}, seeds {list(cross.seeds)})', '',
                  '| statistic | difference D | seed spread S | D / S |', '|---|---|---|---|']
    rep.lines += [f'| {k} | {cross.difference[k]:.4g} | {cross.spread[k]:.4g} | '
                  f'{cross.ratios[k]:.2f} |' for k in cross.difference]
    rep.lines += ['', f'cross_engine_ratio = {cross.cross_engine_ratio:.2f}', '',
                  '![cross-engine](cross_engine.png)', '']


def write_report(out: Path, liggghts: bool, quick: bool = False,
                 cross: tuple[CrossEngineReport, str] | None = None,
                 repose_preset: str | None = None, repose_seeds: int = 1,
                 cases: tuple[str, ...] = CASES,
                 repose_overrides: dict[str, float] | None = None) -> Path:
    """Run the cases and write ``out/report.md``, ``report.json`` and the PNGs.

    Args:
        out: Output directory.
        liggghts: Also run every case on LIGGGHTS.
        quick: Smaller repose pile (the ``quick`` preset) unless ``repose_preset`` is given.
        cross: Cross-engine report and scene name to add, or None.
        repose_preset: Key of ``repose.PRESETS``; None = ``standard`` (``quick`` if quick).
        repose_seeds: Number of repose seeds (0, 1, ...).
        cases: Which of ``CASES`` to run.
        repose_overrides: Repose set-up fields replaced in the preset (SI units).
    """
    import matplotlib

    matplotlib.use('Agg')
    out.mkdir(parents=True, exist_ok=True)
    rep = Report(out, liggghts, {}, ['# dempath physics validation', '',
                                     f'LIGGGHTS runs: {"yes" if liggghts else "no"}.', ''])
    for name, run in (('impact', _impact), ('incline', _incline), ('energy', _energy)):
        if name in cases:
            run(rep)
    if 'repose' in cases:
        preset = repose_preset or ('quick' if quick else 'standard')
        _repose(rep, [repose.preset_case(preset, seed, repose_overrides)
                      for seed in range(repose_seeds)], preset, repose_overrides)
    if cross is not None:
        cross_engine_section(rep, *cross)
    (out / 'report.md').write_text('\n'.join(rep.lines) + '\n')
    (out / 'report.json').write_text(json.dumps(rep.figures, indent=2, default=float))
    return out / 'report.md'
