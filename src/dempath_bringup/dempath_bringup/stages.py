"""The demo's measurement stages: calibration, the node graph, the comparison outputs.

Each stage is ``stage(ctx) -> str`` (printable result lines) over a shared
:class:`~dempath_bringup.context.DemoContext`, whose field for the stage it sets to its typed
result; :mod:`dempath_bringup.demo` runs them in order as named steps, and
:mod:`dempath_bringup.analysis` holds the stages after them (diagnosis, recalibration, report).
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import numpy as np

from dempath.errors import DempathError
from dempath_bringup.context import CalibrationStage, ComparisonStage, DemoContext, need
from dempath_bringup.nodes.graph import METHOD, GraphSpec, field_truth_error, run_graph

LIVE_TOL_PCT = 1e-6  # live and recorded Table 7 agree to rounding [% nRMSE]
SQUARE_MM = 40.4  # the paper's ChArUco squares
PAPER_RMSE_PX = {'side': 0.49, 'front': 0.57}  # the paper's calibration RMSE
START_MARGIN_S = 0.002  # the player starts this long before the first field image [s]
DETECT_RATE = 0.25  # playback speed of images: both detectors keep up on a loaded machine


def truth_json(bag: Path) -> Path:
    """The truth file a synthetic recording keeps beside itself (``<bag>.truth.json``)."""
    return bag.with_name(bag.name + '.truth.json')


def calibrate_stage(ctx: DemoContext) -> str:
    """ChArUco calibration of both cameras from the board views; checked against the truth."""
    from dempath_bringup.calibstep import (
        calibrate_recording,
        check_against_truth,
        truth_cameras,
        truth_lines,
    )
    from dempath_calib.outputs import save_result

    assert ctx.progress is not None
    with ctx.progress('detecting the board') as bar:
        run = calibrate_recording(ctx.calib_source, bar)
    result = run.result
    paths = save_result(result, ctx.out / 'calibration', {'inputs': [str(ctx.calib_source)]})
    checks = check_against_truth(result.calibration, truth_cameras(truth_json(ctx.calib_source)))
    ctx.calibration = CalibrationStage(run, paths['stereo.yaml'], checks)
    rep = result.report
    spacing = rep['corner_spacing']
    field_start = ('' if run.field_start_s is None else
                   f'\nfield segment from {run.field_start_s - run.first_stamp_s:.3f} s into '
                   f'the recording (after the last of {len(run.board_stamps)} board images)')
    return (f"RMSE side {rep['rmse_px']['side']:.3f} px, front {rep['rmse_px']['front']:.3f} px "
            f"(paper {PAPER_RMSE_PX['side']} / {PAPER_RMSE_PX['front']} px), "
            f"{rep['views']['side']}+{rep['views']['front']} views\n"
            f"corner-distance check: {spacing['mean_mm']:.2f} mm for {SQUARE_MM} mm squares "
            f"(paper 40.43 mm)\n{truth_lines(checks)}{field_start}\n{paths['stereo.yaml']}")


def corner_error(ctx: DemoContext, reconstructor: Any) -> str:
    """3D error of the reconstructor node's fitted method on the calibration corners."""
    ps = need(ctx.calibration, 'calibration').result.point_set
    err_mm = 1e3 * np.linalg.norm(reconstructor.predict(ps.pixels) - ps.xyz, axis=1)
    return (f'{METHOD} (fitted by the reconstructor node) on the {len(ps.xyz)} calibration '
            f'corners: mean 3D error {np.nanmean(err_mm):.2f} mm, max {np.nanmax(err_mm):.2f} mm')


def graph_spec(ctx: DemoContext, bag: Path) -> GraphSpec:
    """The node graph of this demo: detection from images, or the bag's clicked points."""
    calibration = need(ctx.calibration, 'calibration')
    run = calibration.run
    offset = 0.0
    if not ctx.clicked and run.field_start_s is not None and \
            ctx.calib_source.resolve() == ctx.field_bag.resolve():
        offset = max(run.field_start_s - run.first_stamp_s - START_MARGIN_S, 0.0)
    rate = ctx.rate if ctx.clicked else ctx.rate * DETECT_RATE
    return GraphSpec(field_bag=ctx.field_bag, calibration=calibration.stereo_yaml,
                     scene=ctx.scene, output=bag, method=METHOD, rate=rate,
                     experiment=ctx.field_bag.name, detect=not ctx.clicked,
                     start_offset_s=offset)


def graph_stage(ctx: DemoContext) -> str:
    """Field bag -> player -> detectors -> reconstructor; simulator; comparer; recorder."""
    bag = ctx.out / f'run_{ctx.field_bag.name}'
    if bag.exists():
        shutil.rmtree(bag)
    spec = graph_spec(ctx, bag)
    assert ctx.progress is not None
    with ctx.progress('graph', None) as bar:
        graph = run_graph(spec, lambda text: bar(0, None, text))
    ctx.graph = graph
    if graph.live is None:
        msg = f'{spec.scene}: the comparer node published no scores'
        raise DempathError(msg)
    lines = [corner_error(ctx, graph.reconstructor), graph.text()]
    lines += detection_lines(graph.detection)
    err = truth_error(ctx, bag)
    if err is not None:
        ctx.traj_rms_mm = err[2]
        lines.append(f"reconstructed vs the recording's true markers: mean {err[0]:.2f} mm, "
                     f'max {err[1]:.2f} mm, RMS {err[2]:.2f} mm')
    if truth_json(ctx.field_bag).is_file():
        from dempath_bringup.truth import surface_coverage

        ctx.surface_coverage = surface_coverage(bag, truth_json(ctx.field_bag))
        if ctx.surface_coverage is not None:
            lines.append('markers reconstructed in at least 80 % of the frames the truth has '
                         'them on the surface: {} of {}'.format(*ctx.surface_coverage))
    return '\n'.join(lines)


def detection_lines(report: dict[str, Any]) -> list[str]:
    """The detectors' counts per camera, and where a camera's images stopped or had gaps."""
    lines = []
    for cam, c in report.items():
        faults = [f'{c[k]} {k.replace("_", " ")}' for k in
                  ('dropped', 'undecodable', 'out_of_order', 'no_marker', 'unnumbered') if c[k]]
        lines.append(f"{cam}: {c['frames']} frames, {c['detected']} detections, {c['tracked']} "
                     f"numbered, {c['lost']} lost, {c['reattached']} re-attached"
                     + (f"; {', '.join(faults)}" if faults else ''))
    frames = {cam: c['frames'] for cam, c in report.items()}
    if frames and len(set(frames.values())) > 1:
        short = min(frames, key=lambda k: frames[k])
        lines.append(f'warning: {short} delivered {frames[short]} images, the other camera '
                     f'{max(frames.values())}: its topic stopped or lost frames; the 3D points '
                     'cover only the frames both cameras saw')
    return lines


def truth_error(ctx: DemoContext, bag: Path) -> tuple[float, float, float] | None:
    """(mean, max, RMS) mm of the recorded 3D markers from the recording's truth, if it has one."""
    from dempath_bringup.truth import render_truth_error

    csv_truth = ctx.field_bag.with_name(ctx.field_bag.name + '.truth.csv')
    if truth_json(ctx.field_bag).is_file() and not csv_truth.is_file():
        return render_truth_error(bag, truth_json(ctx.field_bag))
    if csv_truth.is_file():
        mean, peak, rms = field_truth_error(bag, csv_truth)
        return mean, peak, rms
    return None


def named_identity() -> Any:
    """The demo's comparison settings: the defaults, with tool speed and seed read from names.

    The demo's recordings and scenes name their tool speed (``field_render_reduced_1ms``,
    ``reduced_1ms``) and the bag's topics carry no run metadata, so the demo asks for the name
    convention explicitly (``CompareConfig.identity_from_names``; the comparer node gets the
    same parameter): its Table 7 rows are labelled with the speed and set beside the paper's
    figure for that speed.
    """
    from dempath_compare.config import CompareConfig

    return CompareConfig(identity_from_names=True)


def compare_stage(ctx: DemoContext) -> str:
    """Offline comparison outputs from the recorded bag, checked against the node's scores."""
    from dempath_compare.comparison_folder import write_outputs
    from dempath_compare.pipeline import compare_paths
    from dempath_compare.summary import build_table7

    graph = need(ctx.graph, 'graph')
    result = compare_paths(graph.bag, graph.bag, named_identity())
    outputs = write_outputs(result, ctx.out / 'compare')
    live = build_table7(graph.live)
    gap = table7_gap(live, build_table7(result))
    ctx.comparison = ComparisonStage(result, live, outputs)
    return (f'{table7_text(live)}\nworkbook {outputs.workbook}\nreport   {outputs.report}\n'
            f'table 7  {outputs.table7_md}\nplots    {len(outputs.best_plots)} XZ/YZ + '
            f'{len(outputs.tracked_plots)} 3D in {outputs.report.parent}\n'
            f"the recorded bag's comparison agrees with the comparer node's live scores "
            f'(largest nRMSE difference {gap:.1e} %)')


def table7_text(table: Any) -> str:
    """Table 7 of the scores (mean over the N best model particles) as printable lines."""
    lines = ['marker  MAE [mm]   RMSE [mm]  range [mm]  nRMSE [%]  (mean over the N best)']
    for row in table.rows:
        lines.append(f'{row.marker:>6}  {row.mae_mean * 1e3:8.2f}  {row.rmse_mean * 1e3:9.2f}  '
                     f'{row.range_m * 1e3:10.1f}  {row.nrmse:9.2f}')
    means = ', '.join(f'{k}: {v:.2f} %' for k, v in table.mean_nrmse.items())
    lines.append(f'mean nRMSE {means} (paper: 4.7 % at 1 m/s)')
    return '\n'.join(lines)


def table7_gap(live: Any, recorded: Any) -> float:
    """Largest |nRMSE| difference [%] between two Table 7s of the same markers.

    Raises:
        DempathError: different markers, or a difference above ``LIVE_TOL_PCT``.
    """
    a = {r.marker: r.nrmse for r in live.rows}
    b = {r.marker: r.nrmse for r in recorded.rows}
    if a.keys() != b.keys():
        msg = (f'comparison: the comparer node scored markers {sorted(a)}, the recorded bag '
               f'gives {sorted(b)}')
        raise DempathError(msg)
    gap = max((abs(a[m] - b[m]) for m in a), default=0.0)
    if not gap <= LIVE_TOL_PCT:
        msg = f'comparison: live and recorded Table 7 differ by {gap:.3g} % nRMSE'
        raise DempathError(msg)
    return gap
