"""The demo's model stages after the comparison: diagnosis, recalibration, the model after it.

The diagnosis (:func:`~dempath_diagnose.entry.diagnosis.run_diagnosis`, what ``dempath
diagnose`` calls) reads the recorded bag's MarkerPoints3D and needs the demo scene's signature
library. When the library is not there, the stage says so in one clear line and the demo goes
on without the diagnosis and the recalibration (the library of a scene takes hours to build
here; it ships packed with the package once built). The recalibration
(:func:`~dempath_diagnose.entry.recalibration.run_recalibration`) builds on that diagnosis, fits
the named effect's strength with a small simulation budget and writes the recalibrated scene,
whose fitted values the next stage runs once more
(:func:`~dempath_sim.runs.folder.run_to_folder`) and compares with the same measurement (the
"after" of the report). Each stage passes its typed outcome on through the context.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from dempath.errors import DempathError
from dempath_bringup.context import ComparisonStage, DemoContext, DiagnosisStage, need
from dempath_bringup.stages import named_identity
from dempath_diagnose.entry.requests import DEFAULT_BUDGET, DEFAULT_SEEDS, DiagnoseRequest
from dempath_diagnose.library.simulator import LIBRARY_CANDIDATES

SHIPPED_LIBRARIES = 'libraries'  # folder of packed signature libraries in dempath_diagnose/data
# Recalibration simulations of the demo: one real evaluation on two paired library seeds
# (`dempath recalibrate --seeds-per-eval 2`, its default); with the model-after run it keeps a
# fresh-clone `make demo` within its 10 minutes on this 2-core machine (docs/demo.md).
DEMO_BUDGET = 2
HELD_OUT = (3, 8, 13)  # the grid's middle column: left out of the demo's fit, scored apart


def measured_origin(ctx: DemoContext) -> tuple[float, float, float]:
    """Where the measured (field) frame's origin lies in the scene frame [m].

    The field frame is centred on the marker grid on the surface; the model's marker particles
    start on the same grid, so their mean start position (on Y = 0) is that origin.
    """
    model = need(ctx.comparison, 'comparison').result.model
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
    if ctx.measured_csv is not None:
        return ctx.measured_csv
    from dempath import topics
    from dempath.bagio import open_bag

    bag = need(ctx.graph, 'graph').bag
    rows = []
    with open_bag(bag, [topics.MARKER_POINTS]) as reader:
        for raw in reader.messages([topics.MARKER_POINTS]):
            msg = reader.deserialize(raw)
            t_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            rows += [(t_ns, int(m), x, y, z)
                     for m, x, y, z in zip(msg.marker_ids, msg.x, msg.y, msg.z, strict=True)]
    if not rows:
        msg_ = f'{bag}: no MarkerPoints3D to diagnose'
        raise DempathError(msg_)
    t0 = min(r[0] for r in rows)
    path = ctx.out / 'measured.csv'
    lines = ['t,marker,x,y,z'] + [f'{(t - t0) * 1e-9:.6f},{m},{x:.6f},{y:.6f},{z:.6f}'
                                  for t, m, x, y, z in sorted(rows)]
    path.write_text('\n'.join(lines) + '\n')
    ctx.measured_csv = path
    return path


def diagnose_request(ctx: DemoContext, out: Path) -> DiagnoseRequest:
    """The diagnosis of this demo: the recorded markers against the demo's scene and library
    (the budget beyond the library as ``dempath diagnose`` sets it: none with a library file)."""
    o = ctx.options
    return DiagnoseRequest(
        measured=measured_csv(ctx), scene=ctx.scene, out=out, origin=measured_origin(ctx),
        library=o.library_file, library_root=o.library_root, packing_cache=o.packing_cache,
        seeds=o.seeds or DEFAULT_SEEDS, candidates=o.candidates or LIBRARY_CANDIDATES,
        strengths=o.strengths or 2, serial=o.serial,
        budget=0 if o.library_file is not None else DEFAULT_BUDGET, held_out=held_out(ctx))


def held_out(ctx: DemoContext) -> tuple[int, ...]:
    """The markers the demo leaves out of the diagnosis and the fit, to check the fit on:
    the grid's middle column (3, 8, 13) when all of them were measured with the rest."""
    from dempath_diagnose.decision.measure import load_tracks

    measured = {int(m) for m in load_tracks(measured_csv(ctx), (0.0, 0.0, 0.0)).markers}
    return HELD_OUT if set(HELD_OUT) <= measured and len(measured) >= 2 * len(HELD_OUT) \
        else ()


def library_status(request: DiagnoseRequest) -> tuple[bool, str]:
    """(ready, why not) of the signature library the diagnosis would use."""
    from dempath_diagnose.decision.measure import load_tracks
    from dempath_diagnose.entry.diagnosis import library_spec
    from dempath_diagnose.library.simulator import load_scene
    from dempath_diagnose.library.store import library_state

    if request.library is not None:
        ok = request.library.exists()
        return ok, '' if ok else f'{request.library}: library file not found'
    scene = load_scene(request.scene)
    spec = library_spec(request, scene, load_tracks(request.measured, request.origin))
    state, done, total = library_state(scene, spec, request.library_root)
    if state == 'ready':
        return True, ''
    return False, (f'the signature library of scene {scene.name} is {state} ({done} of {total} '
                   'runs; building it takes hours on this machine)')


def diagnosis_stage(ctx: DemoContext) -> str:
    """The diagnosis of the recorded 3D markers, when the scene's library is there."""
    from dempath_diagnose.entry.diagnosis import run_diagnosis
    from dempath_diagnose.report.diagnosis_outputs import ranking_text

    request = diagnose_request(ctx, ctx.out / 'diagnosis')
    ready, why = library_status(request)
    if not ready:
        ctx.diagnosis = DiagnosisStage(request, None, why)
        return (f'MISSING: {why}. The diagnosis and the recalibration are skipped; the demo goes '
                'on (ship the library, or pass --library FILE / --library-root DIR).')
    try:
        outcome = run_diagnosis(request)
    except DempathError as err:
        msg = f'{ctx.scene}: the diagnosis failed ({err})'
        raise DempathError(msg) from err
    ctx.diagnosis = DiagnosisStage(request, outcome)
    data = outcome.data
    rank = [*data['ranking'][:4], data['baseline']]
    ranking = ', '.join(f"{r['effect']} {r['probability']:.2f}" for r in rank)
    return (f"verdict: {data['verdict']}; ranking (probability): {ranking}\n"
            'no measured tool force in the recording: markers only\n'
            f'{outcome.folder / "diagnosis.json"}\n' + ranking_text(data).strip())


def recalibration_stage(ctx: DemoContext) -> str:
    """The recalibration with the named (or top-ranked) effect and a small budget, on the
    diagnosis the demo has just made."""
    from dempath_diagnose.entry.recalibration import run_recalibration, summary_lines
    from dempath_diagnose.entry.requests import RecalibrationRequest
    from dempath_diagnose.recalibration.targets import parse_effects

    diagnosis = need(ctx.diagnosis, 'diagnosis')
    if diagnosis.outcome is None:
        return f'skipped: no diagnosis ({diagnosis.missing})'
    data = diagnosis.outcome.data
    effect = ctx.options.effect
    if effect is None and data['verdict'] == 'inconclusive' and data['ranking']:
        effect = data['ranking'][0]['effect']  # the top-ranked candidate
    out = ctx.out / 'recalibration'
    request = RecalibrationRequest(replace(diagnosis.request, out=out),
                                   effects=parse_effects([effect] if effect else []),
                                   budget=ctx.options.budget)
    try:
        outcome = run_recalibration(request, diagnosis.outcome)
    except DempathError as err:
        msg = f'{ctx.scene}: the recalibration failed ({err})'
        raise DempathError(msg) from err
    if outcome.stop in ('interrupted', 'scheduler_lost'):
        msg = f"{ctx.scene}: the recalibration stopped: {outcome.data['stop_reason']}"
        raise DempathError(msg)
    ctx.recalibration = outcome
    return '\n'.join([*recalibration_lines(outcome.data), str(out),
                      *summary_lines(outcome.data)])


def recalibration_lines(data: dict[str, Any]) -> list[str]:
    """What the recalibration changed and its errors before and after, each beside its own
    like-for-like floor where one was computed.

    Table 7's floors are each model's own (the model before, the fitted model after) with the
    measured samples and pools as large as the figure's; the headline error's are each model's
    band (docs/diagnosis.md); d^2's is the band the loop stopped on (the model at the fitted
    strength played as the measurement by each library seed, :mod:`.headline.d2floor`).
    """
    s = data['strength']
    change = (f"{data['effect']}.{data['parameter']} {s['before']:.4g} -> {s['value']:.4g} "
              f"+- {s['uncertainty']:.2g} {s['unit']}" if data['changed']
              else 'nothing changed')
    from dempath_diagnose.entry.recalibration import d2_floor_text

    lines = [f"{change} ({data['stop_reason']}; {data['simulations']} simulations)",
             f"error d^2 {data['error_before']:.1f} -> {data['error_after']:.1f} "
             f'({d2_floor_text(data)})']
    paper = data.get('paper')
    if paper:
        fl, pb, pa = paper['floor'], paper['before'], paper['after']
        fa = paper.get('floor_after')
        after_floor = (f"; after's own floor {fa['mean_nrmse_pct']:.2f} +- "
                       f"{fa['mean_nrmse_sd_pct']:.2f} %" if fa else '')
        lines.append(f"mean nRMSE (Table 7, the library's seeds) {pb['mean_nrmse_pct']:.2f} -> "
                     f"{pa['mean_nrmse_pct']:.2f} % (before's floor {fl['mean_nrmse_pct']:.2f} "
                     f"+- {fl['mean_nrmse_sd_pct']:.2f} %{after_floor})")
        head = paper.get('headline') or {}
        if all((head.get(k) or {}).get('value_mm') is not None for k in ('before', 'after')):
            from dempath_diagnose.headline.stage import headline_sentence

            lines += [headline_sentence(head['before'], 'before'),
                      headline_sentence(head['after'], 'after')]
        if paper.get('headline_held_out'):
            from dempath_diagnose.headline.stage import held_out_sentence

            lines += [line for line in [held_out_sentence(paper['headline_held_out'])] if line]
    return lines


def after_stage(ctx: DemoContext) -> str:
    """Run the recalibrated model once and compare it with the same measured markers.

    The model is the demo's scene with the recalibration's fitted values set on it, which is the
    recalibrated scene file's model on the bed the "before" run used: the scene file written by
    the recalibration names the effect among its own, so a run of that file would pour a new bed
    with it (minutes) and the before/after comparison would no longer be on the same packing.
    """
    from dempath_compare.pipeline import compare_paths
    from dempath_compare.summary import build_table7
    from dempath_sim.runs.folder import SimulateRequest, run_to_folder
    from dempath_sim.scene import resolve_scene

    recal = ctx.recalibration
    if recal is None or not recal.best.changed:
        return 'skipped: no recalibrated model'
    out = ctx.out / 'model_after'
    fitted = {f'{p.name}.{p.parameter}': p.value for p in recal.best.params}
    try:
        scene = resolve_scene(ctx.scene).with_overrides(fitted)
        run_to_folder(SimulateRequest(scene, out, ctx.options.packing_cache))
    except (DempathError, OSError) as err:
        msg = f'{recal.scene_file}: the recalibrated model failed ({err})'
        raise DempathError(msg) from err
    result = compare_paths(need(ctx.graph, 'graph').bag, after_model_source(out),
                           named_identity())
    table = build_table7(result)
    ctx.after = ComparisonStage(result, table)
    before = need(ctx.comparison, 'comparison').table7.mean_nrmse
    means = ', '.join(f'{k}: {before.get(k, float("nan")):.2f} -> {v:.2f} %'
                      for k, v in table.mean_nrmse.items())
    # no floor beside it: the library's Table 7 floor has other candidate pools (issue 26)
    return (f'mean nRMSE of this recording {means} (no like-for-like floor: one run per model, '
            f"its candidate pool is not the library floor's)\n{out}")


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
    graph = need(ctx.graph, 'graph')
    calibration = need(ctx.calibration, 'calibration')
    comparison = need(ctx.comparison, 'comparison')
    diagnosed = ctx.diagnosis.outcome if ctx.diagnosis is not None else None
    diag = diagnosed.folder if diagnosed is not None else ctx.out / 'diagnosis'
    recal = ctx.recalibration.request.out if ctx.recalibration else ctx.out / 'recalibration'
    figs: dict[str, str | None] = {
        'calibration': figures.plot_calibration(calibration.result, calibration.truth,
                                                folder / 'calibration.png').name,
        'trajectories': figures.plot_trajectories(
            {'before': comparison.result,
             'after': ctx.after.result if ctx.after is not None else None},
            folder / 'trajectories.png').name,
        'error_map': copy_figure(diag / 'error_map.png', folder, 'error_map.png'),
        'iterations': copy_figure(recal / 'recalibration.png', folder,
                                  'error_vs_iteration.png'),
        'recal_trajectories': copy_figure(recal / 'trajectories.png', folder,
                                          'recalibration_trajectories.png'),
        'headline': copy_figure(recal / 'headline.png', folder, 'headline.png'),
        'headline_iterations': copy_figure(recal / 'headline_iterations.png', folder,
                                           'headline_iterations.png'),
        'statistics': copy_figure(diag / 'statistics.png', folder, 'statistics.png')}
    try:
        coverage = figures.marker_coverage(measured_csv(ctx))
    except DempathError:  # no 3D point recorded: the detection section says so
        coverage = None
    figs['coverage'] = (figures.plot_marker_coverage(coverage, folder / 'coverage.png').name
                        if coverage else None)
    drawn = None if ctx.clicked else figures.frame_with_detections(
        ctx.field_bag, graph.bag, folder / 'detections.png')
    figs['detections'] = drawn.name if drawn is not None else None
    files = {'MCAP bag (Foxglove)': str(graph.bag),
             'stereo calibration': str(calibration.stereo_yaml),
             'comparison report': str(comparison.outputs.report if comparison.outputs else '-')}
    if ctx.recalibration is not None:
        files['recalibrated scene'] = str(ctx.recalibration.scene_file)
    detection = '; '.join(detection_lines(graph.detection)) or 'clicked points (no detection)'
    if ctx.traj_rms_mm is not None:
        detection += (". Reconstructed 3D markers vs the recording's truth: RMS "
                      f'{ctx.traj_rms_mm:.2f} mm.')
    if coverage:
        detection += (f". Markers reconstructed in 3D in at least 80 % of the pass's "
                      f"{coverage['frames']} frames: {len(coverage['reconstructed'])} of "
                      f"{len(coverage['present'])} "
                      f"({', '.join(map(str, coverage['reconstructed']))})")
    if ctx.surface_coverage is not None:
        got, total = ctx.surface_coverage
        detection += (f"; counted over the frames in which the twin's truth has each marker on "
                      f'the surface (a marker buried by the heave no camera can see): {got} of '
                      f'{total}')
    meta = {'title': f'{ctx.field_bag.name} against scene {ctx.scene}',
            'what': (f'Field recording {ctx.field_bag}, calibration from {ctx.calib_source}, '
                     f'model scene {ctx.scene}.'),
            'stages': ctx.stage_s, 'files': files, 'detection': detection}
    page = write_report(ctx, figs, folder, meta)
    made = sorted(k for k, v in figs.items() if v)
    return f'{page} ({len(made)} figures: {", ".join(made)})'
