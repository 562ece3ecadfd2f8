"""Outputs of ``dempath recalibrate``: the new scene, recalibration.json, diagnosis.json's
additions, the error-vs-iteration plot and recalibration.md."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from dempath.errors import OutputError
from dempath_diagnose.recalibrate import Recalibration
from dempath_diagnose.simulate import SceneSpec, write_scene

STOPS = {'floor': 'the error reached the floor (no longer significantly above what the true '
                  'model gives over packing seeds)',
         'budget': 'the simulation budget was used up',
         'stalled': 'the error stopped falling',
         'interrupted': 'interrupted (Ctrl-C); the best strength so far is kept',
         'scheduler_lost': 'the Dask scheduler went away; the best strength so far is kept',
         'nothing_to_fit': 'the scene already fits within the floor; nothing changed'}


def to_json(r: Recalibration) -> dict[str, Any]:
    """recalibration.json's content (d^2 errors, the floor, the steps)."""
    return {'effect': r.effect, 'parameter': r.parameter, 'changed': r.changed, 'stop': r.stop,
            'stop_reason': STOPS.get(r.stop, r.stop), 'note': r.note,
            'strength': {'value': r.strength, 'uncertainty': r.strength_sd, 'unit': r.unit,
                         'before': r.current},
            'error_before': r.before, 'error_after': r.after,
            'floor': {'k': r.floor_k, 'significant': r.floor_significant},
            'error_reduction': r.reduction, 'failures': r.failures,
            'simulations': r.steps[-1].simulations,
            'steps': [vars(s) for s in r.steps]}


def scene_comments(r: Recalibration, scene_name: str) -> list[str]:
    """The YAML header of the recalibrated scene: what changed and why."""
    lines = [f'Recalibrated by dempath recalibrate from scene {scene_name}.']
    if r.changed:
        lines += [f'Changed: {r.effect}.{r.parameter} {r.current:g} -> {r.strength:.6g} {r.unit} '
                  f'(+- {r.strength_sd:.2g}; effect switched on if it was off).',
                  f'Why: the diagnosis named {r.effect}; with it the error d^2 of the group '
                  f'statistics fell from {r.before:.1f} to {r.after:.1f} (floor {r.floor_k}, '
                  f'significant above {r.floor_significant:.1f}).']
    else:
        lines.append('Nothing changed: ' + STOPS.get(r.stop, r.stop) + '.')
    return lines


def write_all(r: Recalibration, scene: SceneSpec, out: Path,
              extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """Write every output into ``out``; returns recalibration.json's content."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        overrides = _overrides(r, scene) if r.changed else {}
        write_scene(scene, overrides, out / f'{scene.name}.recalibrated.yaml',
                    scene_comments(r, scene.name))
        data = {**to_json(r), **(extra or {})}
        (out / 'recalibration.json').write_text(json.dumps(data, indent=2, default=float))
        _update_diagnosis(out / 'diagnosis.json', data)
        plot = plot_steps(r, out / 'recalibration.png')
        (out / 'recalibration.md').write_text(markdown(data, plot))
    except OSError as err:
        raise OutputError(f'{out}: cannot write the recalibration ({err})') from err
    return data


def _overrides(r: Recalibration, scene: SceneSpec) -> dict[str, float]:
    from dempath_diagnose.simulate import scene_candidates

    (cand,) = scene_candidates(scene, (r.effect,))
    return cand.overrides(r.strength)


def _update_diagnosis(path: Path, data: dict[str, Any]) -> None:
    """Add ``error_after`` and the fitted strengths to diagnosis.json (kept if absent)."""
    if not path.is_file():
        return
    diag = json.loads(path.read_text())
    diag['error_after'] = {'d2': data['error_after'], 'd2_before': data['error_before'],
                           'floor': data['floor'], **data.get('paper_after', {})}
    diag.setdefault('recalibration', {})[data['effect']] = {
        'strength': data['strength'], 'stop': data['stop'], 'changed': data['changed']}
    tmp = path.with_suffix('.tmp')
    tmp.write_text(json.dumps(diag, indent=2, default=float))
    tmp.replace(path)


def plot_steps(r: Recalibration, path: Path) -> str:
    """Error vs iteration with the floor band, the fitted strength below."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from scipy import stats

    it = [s.iteration for s in r.steps]
    err = [s.error if s.error != float('inf') else float('nan') for s in r.steps]
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(6, 5))
    a.plot(it, err, 'o-', label='error d$^2$ (real runs)')
    a.plot(it, [s.emulated for s in r.steps], 'x--', label='emulated')
    a.axhspan(stats.chi2.ppf(0.025, r.floor_k), stats.chi2.ppf(0.975, r.floor_k),
              color='0.85', label='floor (true model over seeds, 95 %)')
    a.set_yscale('log')
    a.set_ylabel('d$^2$')
    a.legend(fontsize=8)
    b.plot(it, [s.strength for s in r.steps], 'o-')
    b.set_ylabel(f'{r.parameter} [{r.unit}]')
    b.set_xlabel('iteration')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path.name


def markdown(data: dict[str, Any], plot: str) -> str:
    """recalibration.md: what changed, error before/after beside the floor, the plot."""
    s = data['strength']
    lines = [f'# Recalibration: {data["effect"]}', '', f'Stopped: {data["stop_reason"]}.', '',
             f'- {data["parameter"]}: {s["before"]:g} -> {s["value"]:.6g} +- '
             f'{s["uncertainty"]:.2g} {s["unit"]}',
             f'- error d^2: {data["error_before"]:.1f} -> {data["error_after"]:.1f} (floor '
             f'{data["floor"]["k"]}, significant above {data["floor"]["significant"]:.1f}); '
             f'{100 * data["error_reduction"]:.0f} % of the error above the floor removed',
             f'- simulations: {data["simulations"]} ({data["failures"]} failed candidates)', '',
             f'![error vs iteration]({plot})', '']
    return '\n'.join(lines)
