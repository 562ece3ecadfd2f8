"""Outputs of ``dempath recalibrate``: the new scene, recalibration.json, diagnosis.json's
additions, the figures and recalibration.md (:mod:`dempath_diagnose.report.recalibration_figures`).

Written in that order and each file atomically where it matters (diagnosis.json), so an
interrupted or failed recalibration still leaves the best scene so far and what was computed.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from dempath.errors import OutputError
from dempath_diagnose.library.simulator import SceneSpec, scene_candidates, write_scene
from dempath_diagnose.recalibration.loop import Recalibration

STOPS = {'floor': 'the error reached the floor (no longer above what the true model gives '
                  'over packing seeds)',
         'budget': 'the simulation budget was used up',
         'stalled': 'the error stopped falling',
         'interrupted': 'interrupted (Ctrl-C); the best strengths so far are kept',
         'scheduler_lost': 'the Dask scheduler went away; the best strengths so far are kept',
         'nothing_to_fit': 'the scene already fits within the floor; nothing changed'}


def to_json(r: Recalibration) -> dict[str, Any]:
    """recalibration.json's content (d^2 errors, the floor, the fitted strengths, the steps)."""
    params = [{'name': p.name, 'parameter': p.parameter, 'value': p.value,
               'uncertainty': p.sd, 'unit': p.unit, 'before': p.current} for p in r.params]
    f = r.floor
    return {'effect': r.effect, 'parameter': r.params[0].parameter, 'changed': r.changed,
            'stop': r.stop, 'stop_reason': STOPS.get(r.stop, r.stop), 'note': r.note,
            'strength': {k: params[0][k] for k in ('value', 'uncertainty', 'unit', 'before')},
            'parameters': params,
            'error_before': r.before, 'error_after': r.after,
            'floor': {'k': f.k, 'low': f.low, 'high': f.high, 'significant': f.significant},
            'floor_bands': [{k: v for k, v in b.items() if k != 'samples'}
                            for b in r.floor_bands],
            'stopped_on': ('the like-for-like d^2 floor band' if r.floor_bands
                           else 'the nominal chi^2 mean k'),
            'error_reduction': r.reduction, 'failures': r.failures,
            'simulations': r.steps[-1].simulations,
            'steps': [{**vars(s), 'strengths': list(s.strengths)} for s in r.steps]}


def scene_comments(r: Recalibration, scene_name: str) -> list[str]:
    """The YAML header of the recalibrated scene: what changed and why."""
    lines = [f'Recalibrated by dempath recalibrate from scene {scene_name}.']
    if r.changed:
        lines += [f'Changed: {p.name}.{p.parameter} {p.current:g} -> {p.value:.6g} {p.unit} '
                  f'(+- {p.sd:.2g}; effect switched on if it was off).' for p in r.params]
        band = r.floor_bands[-1] if r.floor_bands else None
        floor = (f"the fitted model's like-for-like band {band['low']:.1f}-{band['high']:.1f}"
                 if band else f'nominal floor chi^2 mean {r.floor.k}, no like-for-like band')
        lines.append(f'Why: the diagnosis named {r.effect}; with it the error d^2 of the group '
                     f'statistics fell from {r.before:.1f} to {r.after:.1f} ({floor}); '
                     f'stopped: {STOPS.get(r.stop, r.stop)}.')
    else:
        lines.append('Nothing changed: ' + STOPS.get(r.stop, r.stop) + '.')
    return lines


def overrides_of(r: Recalibration, scene: SceneSpec) -> dict[str, float]:
    """Scene overrides of the fitted strengths (empty when nothing changed)."""
    if not r.changed:
        return {}
    cands = scene_candidates(scene, tuple(p.name for p in r.params))
    out: dict[str, float] = {}
    for c, p in zip(cands, r.params, strict=True):
        out.update(c.overrides(p.value))
    return out


def write_scene_of(r: Recalibration, scene: SceneSpec, out: Path) -> Path:
    """The recalibrated scene (written first: the best so far survives whatever follows)."""
    path = out / f'{scene.name}.recalibrated.yaml'
    try:
        out.mkdir(parents=True, exist_ok=True)
        write_scene(scene, overrides_of(r, scene), path, scene_comments(r, scene.name))
    except OSError as err:
        raise OutputError(f'{path}: cannot write the recalibrated scene ({err})') from err
    return path


def write_all(r: Recalibration, scene: SceneSpec, out: Path, extra: dict[str, Any] | None = None,
              figures: tuple[str, ...] = ()) -> dict[str, Any]:
    """Write every output into ``out``; returns recalibration.json's content.

    ``extra`` adds keys (``tried``, ``paper``); ``figures`` names figures already written.
    """
    from dempath_diagnose.report.recalibration_figures import markdown, plot_steps

    write_scene_of(r, scene, out)
    try:
        data = {**to_json(r), **(extra or {})}
        (out / 'recalibration.json').write_text(json.dumps(data, indent=2, default=float))
        update_diagnosis(out / 'diagnosis.json', data)
        plot = plot_steps(r, out / 'recalibration.png')
        (out / 'recalibration.md').write_text(markdown(data, (plot, *figures)))
    except OSError as err:
        raise OutputError(f'{out}: cannot write the recalibration ({err})') from err
    return data


def update_diagnosis(path: Path, data: dict[str, Any]) -> None:
    """Add ``error_after`` (d^2 and the paper's metrics, each beside the floor) and the fitted
    strengths with uncertainties to diagnosis.json (nothing when it is absent)."""
    if not path.is_file():
        return
    diag = json.loads(path.read_text())
    after: dict[str, Any] = {'d2': data['error_after'], 'd2_before': data['error_before'],
                             'floor': data['floor'], 'error_reduction': data['error_reduction']}
    paper = data.get('paper')
    if paper:
        after['paper'] = {'mean_nrmse_pct': paper['after']['mean_nrmse_pct'],
                          'mean_nrmse_before_pct': paper['before']['mean_nrmse_pct'],
                          'table7': paper['after']['markers'],
                          'table7_before': paper['before']['markers'],
                          'floor': paper['floor']}
        if paper.get('headline'):
            after['headline'] = paper['headline']
    diag['error_after'] = after
    diag.setdefault('recalibration', {})[data['effect']] = {
        'strengths': data['parameters'], 'stop': data['stop'], 'changed': data['changed'],
        'simulations': data['simulations']}
    tmp = path.with_suffix('.tmp')
    tmp.write_text(json.dumps(diag, indent=2, default=float))
    tmp.replace(path)
