"""``dempath demo``: the whole product on bundled data, from camera images to a recalibrated model.

Named steps, each printing its result and its time (long ones show a rich progress bar):

1. calibration: ChArUco calibration of both cameras from the board segment at the start of the
   rendered recording ``<data>/field_render_reduced_1ms`` (checked against its truth file);
2. graph: the recording's images from the end of the board segment -> player -> one detector
   node per camera (detection, tracking, numbering; PixelPoints ``SOURCE_DETECTED``) ->
   reconstructor node -> MarkerPoints3D; the simulator node runs the scene's current model; the
   comparer node scores it; the recorder writes every topic (MarkerArrays for Foxglove too)
   into one MCAP bag;
3. comparison outputs (workbook, plots, Table 7) from the recorded bag;
4. diagnosis of the missing effect (``dempath diagnose``; needs the scene's signature library,
   else says so and goes on); 5. recalibration with the named effect (``dempath recalibrate``,
   small budget); 6. the recalibrated model run and compared again;
7. the report: ``<out>/report/index.html`` with its PNGs.

``--clicked`` runs the old path: the clicked pixel points of ``<data>/field_twin_reduced_1ms``
(calibrated from ``<data>/calib_twin_small``). Ctrl-C stops the demo cleanly: the MCAP bag and
every output already written stay readable, and ``timing.json`` lists the stages that ran.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dempath.errors import DempathError
from dempath_bringup import analysis, stages
from dempath_bringup.context import DemoContext, DemoOptions

DATA = Path('bags')  # the repository's shipped recordings, relative to where the demo runs
RENDER_BAG = 'field_render_reduced_1ms'
CLICKED_BAG = 'field_twin_reduced_1ms'
CLICKED_CALIB_BAG = 'calib_twin_small'
DEMO_OUT = Path('out') / 'demo'
SCENE = 'reduced_1ms'  # the field recording's scene (recorded with a hidden setting)
INTERRUPTED = 130  # exit code after Ctrl-C (128 + SIGINT)


@dataclass(frozen=True)
class Step:
    """One named step of the demo; ``run`` returns its printable result lines."""

    name: str
    what: str
    run: Callable[[DemoContext], str]


STEPS: list[Step] = [
    Step('calibration', 'ChArUco calibration of both cameras from the board views',
         stages.calibrate_stage),
    Step('graph', 'images -> detectors -> reconstructor; simulator (current model); comparer; '
         'recorder -> MCAP', stages.graph_stage),
    Step('comparison outputs', 'workbook, plots, Table 7 from the recorded bag',
         stages.compare_stage),
    Step('diagnosis', 'which physical effect the model misses (as dempath diagnose)',
         analysis.diagnosis_stage),
    Step('recalibration', 'fit the named effect with a small budget (as dempath recalibrate)',
         analysis.recalibration_stage),
    Step('model after', 'run the recalibrated scene and compare it again', analysis.after_stage),
    Step('report', 'one HTML page with its figures', analysis.report_stage),
]


@contextlib.contextmanager
def progress_bar(description: str, total: int | None = None,
                 ) -> Iterator[Callable[[int, int | None, str], None]]:
    """A transient rich progress bar; yields ``update(done, total, note)``."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn('    {task.description}'), BarColumn(),
                  TextColumn('{task.completed}/{task.total}'), TimeElapsedColumn(),
                  TextColumn('{task.fields[note]}'), transient=True) as bar:
        task = bar.add_task(description, total=total, note='')

        def update(done: int, total_: int | None, note: str) -> None:
            bar.update(task, completed=done, total=total_, note=note[:90])

        yield update


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog='dempath demo', description=__doc__.split('\n')[0])
    p.add_argument('--data', type=Path, default=DATA,
                   help=f'folder of the demo recordings ({RENDER_BAG}; with --clicked '
                   f"{CLICKED_BAG}, {CLICKED_CALIB_BAG}); default ./bags, the repository's")
    p.add_argument('--field-bag', type=Path, help=f'field recording (<data>/{RENDER_BAG})')
    p.add_argument('--calib-bag', type=Path,
                   help='bag or frame folder with the board views (default: the field '
                   'recording, which starts with them)')
    p.add_argument('--clicked', action='store_true',
                   help='play clicked pixel points instead of detecting markers in images')
    p.add_argument('--scene', default=SCENE, help='model scene (file or shipped name)')
    p.add_argument('--out', type=Path, default=DEMO_OUT, help='output folder')
    p.add_argument('--rate', type=float, default=1.0, help='playback speed factor')
    lib = p.add_argument_group('diagnosis and recalibration')
    lib.add_argument('--library', type=Path, help='packed signature library file')
    lib.add_argument('--library-root', type=Path, help='signature library cache folder')
    lib.add_argument('--seeds', help='library packing seeds (dempath diagnose --seeds)')
    lib.add_argument('--candidates', help='candidate effects (dempath diagnose --candidates)')
    lib.add_argument('--strengths', type=int, help='strengths per candidate (1 or 2)')
    lib.add_argument('--packing-cache', type=Path, help='packing cache folder')
    lib.add_argument('--budget', type=int, default=analysis.DEMO_BUDGET,
                     help='recalibration simulations (2: one evaluation on two paired seeds)')
    lib.add_argument('--effect', help='fit this effect whatever the diagnosis says '
                     '(dempath recalibrate --effect)')
    return p


def context_of(args: argparse.Namespace) -> DemoContext:
    """The demo's inputs from its arguments (the clicked path has its own default bags).

    Raises:
        DempathError: ``--seeds`` that are not integers.
    """
    from dempath_diagnose.cli_options import ints

    if args.clicked:
        field_bag = args.field_bag or args.data / CLICKED_BAG
        calib = args.calib_bag or args.data / CLICKED_CALIB_BAG
    else:
        field_bag = args.field_bag or args.data / RENDER_BAG
        calib = args.calib_bag or field_bag
    library = args.library
    if library is None and args.library_root is None:
        from dempath_bringup.analysis import shipped_library

        library = shipped_library(args.scene)
    options = DemoOptions(
        library_file=library, library_root=args.library_root,
        seeds=ints(args.seeds, '--seeds') if args.seeds else None,
        candidates=tuple(c for c in args.candidates.split(',') if c) if args.candidates
        else None, strengths=args.strengths, packing_cache=args.packing_cache,
        budget=args.budget, effect=args.effect)
    return DemoContext(calib, field_bag, args.scene, args.out, args.rate, args.clicked,
                       options, progress_bar)


def check_inputs(ctx: DemoContext, args: argparse.Namespace) -> str | None:
    """One error line for missing inputs or an unwritable output folder; None when fine."""
    if not (args.field_bag and (args.calib_bag or not args.clicked)) and not args.data.is_dir():
        return (f"{args.data}: no demo data folder (pass --data DIR, the repository's bags/ "
                'folder)')
    if not (ctx.field_bag / 'metadata.yaml').is_file():
        return f'{ctx.field_bag}: not a rosbag2 folder (no metadata.yaml)'
    if not ctx.calib_source.exists():
        return f'{ctx.calib_source}: calibration input not found'
    try:
        ctx.out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        return f'{ctx.out}: cannot create the output folder ({err})'
    return None


def run_steps(ctx: DemoContext, steps: list[Step]) -> int:
    """Run the steps in order, printing each one's result and time; 0, 1 on error, 130 on
    Ctrl-C. ``timing.json`` in the output folder lists the seconds of each finished step."""
    timing: dict[str, Any] = {'stages': {}}
    ctx.stage_s = timing['stages']
    start = time.monotonic()
    code = 0
    for number, step in enumerate(steps, 1):
        print(f'[{number}/{len(steps)}] {step.name}: {step.what}', flush=True)
        t0 = time.monotonic()
        try:
            text = step.run(ctx)
        except DempathError as err:
            print(f'error: {err}', file=sys.stderr)
            code = 1
            break
        except KeyboardInterrupt:
            print(f'interrupted during {step.name}: everything written so far is kept in '
                  f'{ctx.out} (the MCAP bag is closed and readable)', file=sys.stderr)
            code = INTERRUPTED
            break
        seconds = time.monotonic() - t0
        timing['stages'][step.name] = round(seconds, 2)
        print('    ' + text.replace('\n', '\n    ') + f'\n    ({seconds:.1f} s)', flush=True)
    timing.update(demo_s=round(time.monotonic() - start, 1), exit_code=code,
                  traj_rms_mm=ctx.traj_rms_mm,
                  mean_nrmse_pct={name: stage.table7.mean_nrmse for name, stage in
                                  (('before', ctx.comparison), ('after', ctx.after))
                                  if stage is not None})
    (ctx.out / 'timing.json').write_text(json.dumps(timing))
    if code == 0:
        graph = ctx.graph
        print(f'demo finished in {timing["demo_s"]} s; outputs in {ctx.out}:\n'
              f'    report   {ctx.out / "report" / "index.html"}\n'
              f'    MCAP bag {graph.bag if graph is not None else "-"}\n'
              f'    timing   {ctx.out / "timing.json"}')
    return code


def demo_main(argv: list[str]) -> int:
    """``dempath demo``: from camera images to a recalibrated model, on bundled data."""
    args = _parser().parse_args(argv)
    try:
        ctx = context_of(args)
    except DempathError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    problem = check_inputs(ctx, args)
    if problem is not None:
        print(f'error: {problem}', file=sys.stderr)
        return 1
    return run_steps(ctx, STEPS)
