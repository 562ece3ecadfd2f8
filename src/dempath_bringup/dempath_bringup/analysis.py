"""The demo's model stages after the comparison: diagnosis, recalibration, the model after it.

The diagnosis (``dempath diagnose``) reads the recorded bag's MarkerPoints3D and needs the demo
scene's signature library. When the library is not there, the stage says so in one clear line
and the demo goes on without the diagnosis and the recalibration (the library of a scene takes
hours to build here; it ships packed with the package once built). The recalibration
(``dempath recalibrate``) fits the named effect's strength with a small simulation budget and
writes the recalibrated scene, which the last stage runs once more and compares with the same
measurement (the "after" of the report).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
from pathlib import Path
from typing import Any

import numpy as np

from dempath.errors import DempathError
from dempath_bringup.stages import DemoContext, named_identity

SHIPPED_LIBRARIES = 'libraries'  # folder of packed signature libraries in dempath_diagnose/data
# Recalibration simulations of the demo: one real evaluation on two paired library seeds
# (`dempath recalibrate --seeds-per-eval 2`, its default); with the model-after run it keeps a
# fresh-clone `make demo` within its 10 minutes on this 2-core machine (docs/demo.md).
DEMO_BUDGET = 2


def measured_origin(ctx: DemoContext) -> tuple[float, float, float]:
    """Where the measured (field) frame's origin lies in the scene frame [m].

    The field frame is centred on the marker grid on the surface; the model's marker particles
    start on the same grid, so their mean start position (on Y = 0) is that origin.
    """
    model = ctx.results['compare_before'].model
    keep = (model.marker_ids > 0) & np.isfinite(model.origins).all(1)
    if not keep.any():
        return 0.0, 0.0, 0.0
    centre = model.origins[keep].mean(0)
    return float(centre[0]), 0.0, float(centre[2])


def shipped_library(scene: str) -> Path | None:
    """The packed signature library shipped for ``scene`` (None when there is none)."""
    from importlib.resources import files

    folder = Path(str(files('dempath_diagnose'))) / 'data' / SHIPPED_LIBRARIES
    name = scene.removeprefix('builtin:')
    found = sorted(folder.glob(f'{name}*')) if folder.is_dir() else []
    return found[0] if found else None


def measured_csv(ctx: DemoContext) -> Path:
    """The recorded MarkerPoints3D as ``measured.csv`` (t,marker,x,y,z; s, m) for the diagnosis.

    The times start at the first 3D frame: the measured pass starts with the recording, as the
    model's run starts at t = 0 (the bag's stamps are camera clock times).
    """
    if 'measured_csv' in ctx.results:
        return Path(ctx.results['measured_csv'])
    from dempath import topics
    from dempath.bagio import open_bag

    rows = []
    with open_bag(ctx.results['graph'].bag, [topics.MARKER_POINTS]) as reader:
        for raw in reader.messages([topics.MARKER_POINTS]):
            msg = reader.deserialize(raw)
            t_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            rows += [(t_ns, int(m), x, y, z)
                     for m, x, y, z in zip(msg.marker_ids, msg.x, msg.y, msg.z, strict=True)]
    if not rows:
        msg_ = f"{ctx.results['graph'].bag}: no MarkerPoints3D to diagnose"
        raise DempathError(msg_)
    t0 = min(r[0] for r in rows)
    path = ctx.out / 'measured.csv'
    lines = ['t,marker,x,y,z'] + [f'{(t - t0) * 1e-9:.6f},{m},{x:.6f},{y:.6f},{z:.6f}'
                                  for t, m, x, y, z in sorted(rows)]
    path.write_text('\n'.join(lines) + '\n')
    ctx.results['measured_csv'] = path
    return path


def diagnose_argv(ctx: DemoContext, out: Path) -> list[str]:
    """The ``dempath diagnose`` arguments of this demo (library options included)."""
    o = ctx.options
    origin = ','.join(f'{v:.6f}' for v in measured_origin(ctx))
    argv = ['--measured', str(measured_csv(ctx)), '--scene', ctx.scene,
            '--origin', origin, '--out', str(out)]
    if o.get('library_file'):
        argv += ['--library', str(o['library_file'])]
    for key, flag in (('library_root', '--library-root'), ('seeds', '--seeds'),
                      ('candidates', '--candidates'), ('strengths', '--strengths'),
                      ('packing_cache', '--packing-cache')):
        if o.get(key) is not None:
            argv += [flag, str(o[key])]
    return argv + (['--serial'] if o.get('serial', True) else [])


def library_status(ctx: DemoContext) -> tuple[bool, str]:
    """(ready, why not) of the signature library the diagnosis would use."""
    from dempath_diagnose.cli import library_spec
    from dempath_diagnose.decision.measure import load_tracks
    from dempath_diagnose.library.simulator import LIBRARY_CANDIDATES, load_scene
    from dempath_diagnose.library.store import library_state

    o = ctx.options
    if o.get('library_file'):
        ok = Path(o['library_file']).exists()
        return ok, '' if ok else f"{o['library_file']}: library file not found"
    scene = load_scene(ctx.scene)
    meas = load_tracks(measured_csv(ctx), measured_origin(ctx))
    ns = argparse.Namespace(measured=measured_csv(ctx),
                            seeds=o.get('seeds') or '1001,1002,1003,1004',
                            candidates=o.get('candidates') or ','.join(LIBRARY_CANDIDATES),
                            strengths=int(o.get('strengths') or 2))
    spec = library_spec(ns, scene, meas)
    state, done, total = library_state(scene, spec, o.get('library_root'))
    if state == 'ready':
        return True, ''
    return False, (f'the signature library of scene {scene.name} is {state} ({done} of {total} '
                   'runs; building it takes hours on this machine)')


def _call(main: Any, argv: list[str]) -> tuple[int, str]:
    """Run a ``dempath`` command function; (exit code, its printed output)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = int(main(argv))
    return code, out.getvalue()


def diagnosis_stage(ctx: DemoContext) -> str:
    """``dempath diagnose`` on the recorded 3D markers, when the scene's library is there."""
    from dempath_diagnose.cli import diagnose_main

    ready, why = library_status(ctx)
    if not ready:
        ctx.results['diagnosis'] = None
        ctx.results['diagnosis_missing'] = why
        return (f'MISSING: {why}. The diagnosis and the recalibration are skipped; the demo goes '
                'on (ship the library, or pass --library FILE / --library-root DIR).')
    out = ctx.out / 'diagnosis'
    argv = diagnose_argv(ctx, out)
    code, text = _call(diagnose_main, argv)
    if code != 0:
        msg = f'{ctx.scene}: the diagnosis failed (dempath diagnose {" ".join(argv)})'
        raise DempathError(msg)
    data = json.loads((out / 'diagnosis.json').read_text())
    ctx.results['diagnosis'] = data
    ctx.results['diagnose_argv'] = argv
    rank = [*data['ranking'][:4], data['baseline']]
    ranking = ', '.join(f"{r['effect']} {r['probability']:.2f}" for r in rank)
    return (f"verdict: {data['verdict']}; ranking (probability): {ranking}\n"
            'no measured tool force in the recording: markers only\n'
            f'{out / "diagnosis.json"}\n' + text.strip())


def recalibration_stage(ctx: DemoContext) -> str:
    """``dempath recalibrate`` with the named (or top-ranked) effect and a small budget."""
    from dempath_diagnose.recalibrate_cli import recalibrate_main

    diag = ctx.results.get('diagnosis')
    if diag is None:
        return f"skipped: no diagnosis ({ctx.results.get('diagnosis_missing', '')})"
    out = ctx.out / 'recalibration'
    argv = [a if a != str(ctx.out / 'diagnosis') else str(out)
            for a in ctx.results['diagnose_argv']]
    argv += ['--budget', str(ctx.options.get('budget', DEMO_BUDGET))]
    if ctx.options.get('effect'):
        argv += ['--effect', str(ctx.options['effect'])]
    elif diag['verdict'] == 'inconclusive' and diag['ranking']:
        argv += ['--effect', diag['ranking'][0]['effect']]  # the top-ranked candidate
    code, text = _call(recalibrate_main, argv)
    if code != 0:
        msg = f'{ctx.scene}: the recalibration failed (dempath recalibrate {" ".join(argv)})'
        raise DempathError(msg)
    data = json.loads((out / 'recalibration.json').read_text())
    ctx.results['recalibration'] = data
    ctx.results['recalibrated_scene'] = next(out.glob('*.recalibrated.yaml'), None)
    return '\n'.join([*recalibration_lines(data), str(out), text.strip()])


def recalibration_lines(data: dict[str, Any]) -> list[str]:
    """What the recalibration changed and its errors before and after, each beside the floor.

    The floor is what the true model itself gives over packing seeds: d^2's chi^2_k mean and
    95 % band, and the paper's mean nRMSE of one seed playing the measurement against the others
    (docs/recalibration.md). A fall is judged against it, not against zero.
    """
    s, f = data['strength'], data['floor']
    change = (f"{data['effect']}.{data['parameter']} {s['before']:.4g} -> {s['value']:.4g} "
              f"+- {s['uncertainty']:.2g} {s['unit']}" if data['changed']
              else 'nothing changed')
    lines = [f"{change} ({data['stop_reason']}; {data['simulations']} simulations)",
             f"error d^2 {data['error_before']:.1f} -> {data['error_after']:.1f} (floor "
             f"{f['k']:g}, the true model's 95 % band {f['low']:.1f}-{f['high']:.1f}); "
             f"{100 * (data.get('error_reduction') or 0.0):.0f} % of the error above the floor "
             'removed']
    paper = data.get('paper')
    if paper:
        fl, pb, pa = paper['floor'], paper['before'], paper['after']
        lines.append(f"mean nRMSE (Table 7, the library's seeds) {pb['mean_nrmse_pct']:.2f} -> "
                     f"{pa['mean_nrmse_pct']:.2f} % (floor {fl['mean_nrmse_pct']:.2f} +- "
                     f"{fl['mean_nrmse_sd_pct']:.2f} %)")
        head = paper.get('headline') or {}
        if all((head.get(k) or {}).get('value_mm') is not None for k in ('before', 'after')):
            from dempath_diagnose.headline.stage import headline_sentence

            lines += [headline_sentence(head['before'], 'before'),
                      headline_sentence(head['after'], 'after')]
    return lines


def after_stage(ctx: DemoContext) -> str:
    """Run the recalibrated model once and compare it with the same measured markers.

    The model is the demo's scene with the recalibration's fitted values set on it (``dempath
    simulate SCENE --effect EFFECT.PARAM=VALUE``), which is the recalibrated scene file's model
    on the bed the "before" run used: the scene file written by the recalibration names the
    effect among its own, so ``dempath simulate`` of that file would pour a new bed with it
    (minutes) and the before/after comparison would no longer be on the same packing.
    """
    from dempath_compare.pipeline import compare_paths
    from dempath_compare.summary import build_table7
    from dempath_sim.cli import simulate_main

    scene = ctx.results.get('recalibrated_scene')
    data = ctx.results.get('recalibration')
    if scene is None or data is None or not data['changed']:
        return 'skipped: no recalibrated model'
    out = ctx.out / 'model_after'
    argv = [ctx.scene, '--out', str(out), '--quiet']
    for p in data['parameters']:
        argv += ['--effect', f"{p['name']}.{p['parameter']}={p['value']!r}"]
    if ctx.options.get('packing_cache') is not None:
        argv += ['--cache-dir', str(ctx.options['packing_cache'])]
    if simulate_main(argv) != 0:
        msg = f'{scene}: the recalibrated model failed (dempath simulate {" ".join(argv)})'
        raise DempathError(msg)
    result = compare_paths(ctx.results['graph'].bag, after_model_source(out), named_identity())
    table = build_table7(result)
    ctx.results.update(compare_after=result, table7_after=table)
    before = ctx.results['table7'].mean_nrmse
    means = ', '.join(f'{k}: {before.get(k, float("nan")):.2f} -> {v:.2f} %'
                      for k, v in table.mean_nrmse.items())
    floor = (data.get('paper') or {}).get('floor')
    beside = (f" (floor {floor['mean_nrmse_pct']:.2f} +- {floor['mean_nrmse_sd_pct']:.2f} %: "
              'the true model over packing seeds)' if floor else '')
    return f'mean nRMSE of this recording {means}{beside}\n{out}'


def after_model_source(run: Path) -> Path:
    """The model side of the 'after' comparison of a ``dempath simulate`` run folder.

    Its ``model.csv`` tags every tracked particle with its marker, so each marker is ranked
    against its own Cube candidates (the N best of them, as the 'before' bag's model); the
    folder itself would add ``markers.csv`` (one particle per marker: every marker's N was 1)
    and ``tool.csv``.
    """
    return run / 'model.csv'


def report_stage(ctx: DemoContext) -> str:
    """The HTML report with its figures in ``<out>/report``."""
    from dempath_bringup import figures
    from dempath_bringup.report import copy_figure, write_report
    from dempath_bringup.stages import detection_lines

    folder = ctx.out / 'report'
    folder.mkdir(parents=True, exist_ok=True)
    r = ctx.results
    graph = r['graph']
    figs: dict[str, str | None] = {
        'calibration': figures.plot_calibration(r['calibration'], r.get('calib_truth') or [],
                                                folder / 'calibration.png').name,
        'trajectories': figures.plot_trajectories(
            {'before': r['compare_before'], 'after': r.get('compare_after')},
            folder / 'trajectories.png').name,
        'error_map': copy_figure(ctx.out / 'diagnosis' / 'error_map.png', folder,
                                 'error_map.png'),
        'iterations': copy_figure(ctx.out / 'recalibration' / 'recalibration.png', folder,
                                  'error_vs_iteration.png'),
        'recal_trajectories': copy_figure(ctx.out / 'recalibration' / 'trajectories.png',
                                          folder, 'recalibration_trajectories.png'),
        'headline': copy_figure(ctx.out / 'recalibration' / 'headline.png', folder,
                                'headline.png'),
        'statistics': copy_figure(ctx.out / 'diagnosis' / 'statistics.png', folder,
                                  'statistics.png')}
    drawn = None if ctx.clicked else figures.frame_with_detections(
        ctx.field_bag, graph.bag, folder / 'detections.png')
    figs['detections'] = drawn.name if drawn is not None else None
    files = {'MCAP bag (Foxglove)': str(graph.bag), 'stereo calibration': str(r['stereo_yaml']),
             'comparison report': str(r['outputs'].report)}
    if r.get('recalibrated_scene') is not None:
        files['recalibrated scene'] = str(r['recalibrated_scene'])
    detection = '; '.join(detection_lines(graph.detection)) or 'clicked points (no detection)'
    err = r.get('traj_rms_mm')
    if err is not None:
        detection += f". Reconstructed 3D markers vs the recording's truth: RMS {err:.2f} mm."
    meta = {'title': f'{ctx.field_bag.name} against scene {ctx.scene}',
            'what': (f'Field recording {ctx.field_bag}, calibration from {ctx.calib_source}, '
                     f'model scene {ctx.scene}.'),
            'stages': r.get('stage_s', {}), 'files': files, 'detection': detection}
    page = write_report(r, figs, folder, meta)
    made = sorted(k for k, v in figs.items() if v)
    return f'{page} ({len(made)} figures: {", ".join(made)})'
