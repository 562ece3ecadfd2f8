"""``dempath diagnose``: where the model fails against a measured pass, and what it misses.

``dempath diagnose --measured M --scene S [--force F] [--origin X,Y,Z] --out DIR
[--scheduler ADDR]``. Bad input gives one ``error: <input>: <problem>`` line and exit code 1;
faults of single markers are warned about and the rest is still diagnosed.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from dempath.errors import DempathError
from dempath_diagnose.admission import check_force_time_base, markers_in_bin
from dempath_diagnose.decision.diagnosis import CaseGeometry, Diagnosis, diagnose
from dempath_diagnose.decision.emulator import Allowance
from dempath_diagnose.decision.measure import load_force, load_tracks
from dempath_diagnose.errors import DiagnosisError, MeasurementError
from dempath_diagnose.library.packed import DEFAULT_MARGIN_M
from dempath_diagnose.library.simulator import (
    BACKENDS,
    LIBRARY_CANDIDATES,
    SceneSpec,
    load_scene,
    pass_travel_s,
    tool_geometry,
)
from dempath_diagnose.library.store import (
    Library,
    LibrarySpec,
    build_library,
    covering_duration,
    library_dir,
    library_state,
    recorded_run_s,
)
from dempath_diagnose.records import Measurement

DEFAULT_BUDGET = 6  # simulations beyond the library (two strengths on the default 3 seeds)
MAX_FOLLOW_S = 5.0  # the model follows the bed at most this long after the tool stops [s]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog='dempath diagnose', description=__doc__.split('\n')[0])
    p.add_argument('--measured', required=True, type=Path,
                   help='CSV t,marker,x,y,z [s, m] or a bag with MarkerPoints3D')
    p.add_argument('--scene', required=True, help='scene file or shipped scene (builtin:tiny)')
    p.add_argument('--force', type=Path, help='CSV t,Fx,Fy,Fz [s, N], force on the tool')
    p.add_argument('--origin', default='0,0,0',
                   help='measured frame origin in the scene frame, X,Y,Z [m]')
    p.add_argument('--out', required=True, type=Path, help='output folder')
    p.add_argument('--scheduler', help='Dask scheduler address (default: a local cluster)')
    p.add_argument('--workers', type=int, default=0, help='local Dask workers (0: by cores)')
    p.add_argument('--library-root', type=Path, help='signature library cache folder')
    p.add_argument('--packing-cache', type=Path, help='packing cache folder')
    p.add_argument('--seeds', default='1001,1002,1003', help='library packing seeds')
    p.add_argument('--candidates', default=','.join(LIBRARY_CANDIDATES),
                   help='candidate effects, comma-separated')
    p.add_argument('--strengths', type=int, default=2, help='strengths per candidate (1 or 2)')
    p.add_argument('--windows', type=int, default=4, help='time windows of the statistics')
    p.add_argument('--noise', type=float, default=Allowance.noise_m,
                   help='measurement noise per axis [m]')
    p.add_argument('--discrepancy', type=float, default=Allowance.discrepancy_m,
                   help='model-discrepancy allowance on marker statistics [m]')
    p.add_argument('--discrepancy-rel', type=float, default=Allowance.discrepancy_rel,
                   help='relative model-discrepancy allowance on marker statistics')
    p.add_argument('--discrepancy-force', type=float, default=Allowance.discrepancy_force_rel,
                   help='relative model-discrepancy allowance on the draft force')
    p.add_argument('--serial', action='store_true', help='run the library here, without Dask')
    p.add_argument('--model', type=Path,
                   help="the paper's Table 7 against this model run of yours instead of the "
                        "library's baseline band: dempath CSV, a LIGGGHTS dump or a mapped "
                        'EDEM/Rocky CSV (with --model-map)')
    p.add_argument('--model-map', type=Path, metavar='YAML',
                   help='how to read --model: columns, units, axes (docs/compare.md)')
    p.add_argument('--backend', choices=BACKENDS, default='dempath',
                   help="engine of the library's runs (liggghts: LIGGGHTS 3.8 from the same "
                        'settled beds)')
    p.add_argument('--library', type=Path,
                   help='use this library (a packed file or a library folder); never built')
    p.add_argument('--export-library', type=Path, metavar='FILE',
                   help="also pack the library into FILE for the measured markers' region")
    p.add_argument('--export-margin', type=float, default=DEFAULT_MARGIN_M,
                   help="packed: particles within this of a marker's cube are kept [m]")
    p.add_argument('--export-box', help='packed: keep the particles starting in this box, '
                   'X0,Y0,Z0,X1,Y1,Z1 [m] (scene frame), besides those near the markers')
    return p


def _floats(text: str, what: str, n: int) -> list[float]:
    try:
        values = [float(v) for v in text.split(',')]
    except ValueError as err:
        raise DiagnosisError(f'{what} {text!r}: expected {n} numbers in metres') from err
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise DiagnosisError(f'{what} {text!r}: expected {n} finite numbers separated by commas')
    return values


def _origin(text: str) -> tuple[float, float, float]:
    values = _floats(text, '--origin', 3)
    return values[0], values[1], values[2]


def _ints(text: str, what: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(',') if v.strip())
    except ValueError as err:
        raise DiagnosisError(f'{what} {text!r}: expected integers separated by commas') from err


def library_spec(args: argparse.Namespace, scene: SceneSpec, meas: Measurement) -> LibrarySpec:
    """The library design that covers the measured window (duration rounded up)."""
    travel = pass_travel_s(scene, {})
    end = float(meas.times[-1])
    if end > travel + MAX_FOLLOW_S:
        msg = (f'{args.measured}: the measured window lasts {end:.2f} s, longer than the model '
               f'can run (travel {travel:.2f} s + at most {MAX_FOLLOW_S:g} s after the stop)')
        raise MeasurementError(msg)
    duration = covering_duration(travel, end)
    cands = tuple(c for c in args.candidates.split(',') if c)
    return LibrarySpec(seeds=_ints(args.seeds, '--seeds'), candidates=cands,
                       duration_s=round(duration, 6), n_strengths=args.strengths)


def ensure_library(args: argparse.Namespace, scene: SceneSpec, spec: LibrarySpec) -> Library:
    """Load the library, building (or completing) it first when needed, saying why and how long
    it will take, with a progress bar."""
    if args.library is not None:
        return Library.load(args.library)
    state, done, total = library_state(scene, spec, args.library_root, args.backend)
    if state != 'ready':
        width = 1 if args.serial else max(1, args.workers or 2)
        per_run, timed = recorded_run_s(scene, spec, args.library_root, args.backend)
        print(library_notice(scene.name, state, done, total, per_run, timed, width),
              file=sys.stderr)
        _build(args, scene, spec, total - done, per_run)
    return Library.load(library_dir(scene, spec, args.library_root, args.backend))


def library_notice(scene: str, state: str, done: int, total: int, per_run_s: float,
                   timed: int, width: int) -> str:
    """The one line said before a library is built: why, how many runs, how long."""
    why = {'missing': 'no signature library yet',
           'stale': "the library is stale (the scene's physics changed since it was built)",
           'partial': f'the library is partial ({done} of {total} runs stored)'}[state]
    todo = total - done
    if per_run_s > 0:
        eta = (f'about {_duration(per_run_s * math.ceil(todo / width))} ({width} at a time, '
               f'{per_run_s:.0f} s per run as recorded in {timed} earlier runs)')
    else:
        eta = 'its time is known after the first run (the progress bar shows the ETA)'
    verb = 'building it' if state != 'partial' else 'completing it'
    return f'{scene}: {why}; {verb}: {todo} simulations, {eta}'


def _duration(seconds: float) -> str:
    if seconds < 90:
        return f'{seconds:.0f} s'
    if seconds < 5400:
        return f'{seconds / 60:.0f} min'
    return f'{seconds / 3600:.1f} h'


def _build(args: argparse.Namespace, scene: SceneSpec, spec: LibrarySpec, todo: int,
           per_run_s: float) -> None:
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from dempath_diagnose.library.store import serial_executor

    bar = Progress(TextColumn('library'), BarColumn(), MofNCompleteColumn(),
                   TimeElapsedColumn(), TextColumn('ETA'), TimeRemainingColumn(),
                   console=None)
    t0 = time.monotonic()
    with bar:
        task = bar.add_task('library', total=todo)

        def on_done(n: int, total: int) -> None:
            bar.update(task, completed=n)
            if n == 1 and per_run_s <= 0 and total > 1:
                spent = time.monotonic() - t0
                bar.console.print(f'{scene.name}: first run took {spent:.0f} s; about '
                                  f'{_duration(spent * (total - 1))} for the other {total - 1} '
                                  'at this rate')

        if args.serial:
            build_library(scene, spec, args.library_root, serial_executor, args.packing_cache,
                          on_done, backend=args.backend)
            return
        from dempath_diagnose.library.sweep import DaskSweep

        with DaskSweep(args.scheduler, args.workers) as sweep:
            build_library(scene, spec, args.library_root, sweep.run, args.packing_cache,
                          on_done, worker_cache=None if sweep.remote else 'same',
                          backend=args.backend)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """The whole command; returns diagnosis.json's content."""
    t0 = time.monotonic()
    scene, _spec, library, allowance, result = diagnosis_of(args)
    result.wall_s = time.monotonic() - t0
    from dempath_diagnose.report.diagnosis_outputs import print_ranking, write_outputs

    extra: dict[str, Any] = {'scene': scene.name, 'library': str(library.folder),
                             'allowance': vars(allowance), 'backend': args.backend}
    if result.adaptive:
        extra['adaptive'] = result.adaptive
    if args.export_library is not None:
        extra['exported_library'] = export(args, library, result, tool_geometry(scene)[2])
    data = write_outputs(result, args.out, extra)
    print_ranking(data)
    return data


def export(args: argparse.Namespace, library: Library, result: Diagnosis,
           cube: tuple[float, float, float]) -> dict[str, Any]:
    """Pack the library for the measured markers (and ``--export-box``) into the export file."""
    from dempath_diagnose.library.packed import export_library

    box = None
    if args.export_box:
        values = _floats(args.export_box, '--export-box', 6)
        box = np.array([values[:3], values[3:]])
    summary = export_library(library, args.export_library, cube, result.layout.starts,
                             args.export_margin, box)
    print(f'packed library: {summary["path"]} ({summary["bytes"] / 1e6:.2f} MB, '
          f'{summary["runs"]} runs, {summary["particles_min"]}-{summary["particles_max"]} '
          'particles each)', file=sys.stderr)
    return summary


def diagnosis_of(args: argparse.Namespace,
                 ) -> tuple[SceneSpec, LibrarySpec, Library, Allowance, Diagnosis]:
    """Scene, library design, library (built when needed), allowance and diagnosis of the parsed
    arguments (what ``dempath recalibrate`` builds on)."""
    origin = _origin(args.origin)
    scene = load_scene(args.scene)
    meas = markers_in_bin(args.measured, load_tracks(args.measured, origin), scene)
    if meas.time_origin:
        print(f'{args.measured}: {meas.time_origin}', file=sys.stderr)
    for marker, problem in sorted(meas.problems.items()):
        print(f'warning: {args.measured}: marker {marker}: {problem} (left out)', file=sys.stderr)
    if args.force is not None:
        t, f = load_force(args.force)
        check_force_time_base(args.force, t, meas.times)
        meas = replace(meas, force_times=t, force=f)
    spec = library_spec(args, scene, meas)
    library = ensure_library(args, scene, spec)  # a given --library is only read
    library.check_scene(scene)  # before any diagnosis is computed or written
    tool_x, half_width, cube = tool_geometry(scene)
    allowance = Allowance(args.noise, args.discrepancy, args.discrepancy_rel,
                          args.discrepancy_force)
    geometry = CaseGeometry(tool_x, half_width, cube)

    def again(lib: Library) -> Diagnosis:
        return diagnose(meas, lib, geometry, allowance, args.windows, str(args.force))

    result = again(library)
    result.simulations = len(library.runs)
    if getattr(args, 'extra_budget', 0) > 0:
        result, library = spend_budget(args, scene, spec, library, result, again)
    if args.model is not None:
        result.table7 = own_model_table7(args, meas, cube)
    return scene, spec, library, allowance, result


def own_model_table7(args: argparse.Namespace, meas: Measurement,
                     cube: tuple[float, float, float]) -> dict[str, Any]:
    """The paper's Table 7 of the user's own model run (``--model``, read as dempath compare
    reads a model) against the measured markers: each marker's Cube candidates in that run."""
    from dempath_compare.foreign import load_mapping
    from dempath_compare.loaders import MODEL, load_source
    from dempath_diagnose.decision.bandtracks import band_table7, model_record

    mapping = load_mapping(args.model_map) if args.model_map is not None else None
    record = model_record(load_source(args.model, MODEL, mapping))
    table = band_table7(meas, [record], cube, [args.model.stem])
    return {**table, 'model': str(args.model)}


def spend_budget(args: argparse.Namespace, scene: SceneSpec, spec: LibrarySpec,
                 library: Library, first: Diagnosis, again: Any) -> tuple[Diagnosis, Library]:
    """``--budget``: simulations beyond the library where they would settle an open answer
    (:mod:`dempath_diagnose.adaptive`), through the library's executor (Dask or serial)."""
    from contextlib import ExitStack

    from dempath_diagnose.adaptive import refine
    from dempath_diagnose.library.store import extend_library, serial_executor

    with ExitStack() as stack:
        executor: Any = serial_executor
        worker_cache: Path | None | str = 'same'
        if not args.serial:
            from dempath_diagnose.library.sweep import DaskSweep

            sweep = None

            def lazy(tasks: Any, done: Any) -> None:  # a cluster only when something runs
                nonlocal sweep
                if sweep is None:
                    sweep = stack.enter_context(DaskSweep(args.scheduler, args.workers))
                sweep.run(tasks, done)

            executor = lazy
            worker_cache = None if args.scheduler else 'same'

        def extend(lib: Library, additions: list[tuple[str, float]], seeds: int) -> Library:
            for name, x in additions:
                print(f'{scene.name}: simulating {name} at {x:.4g} on {seeds} seeds',
                      file=sys.stderr)
            return extend_library(lib, scene, spec, additions, seeds, executor,
                                  args.packing_cache, worker_cache, args.backend)

        final, library, outcome = refine(first, library, again, extend, args.extra_budget)
    final.adaptive = outcome.to_dict()
    print(f'{scene.name}: {outcome.used} simulations beyond the library; {outcome.stop}',
          file=sys.stderr)
    return final, library


def diagnose_main(argv: list[str] | None = None) -> int:
    """``dempath diagnose``: where the model fails against a measured pass, what it misses.

    Returns 0, or 1 after one ``error: <input>: <problem>`` line on bad input.
    """
    parser = _parser()
    parser.add_argument('--budget', dest='extra_budget', type=int, default=None,
                        help='simulations allowed beyond the library where they would settle '
                             f'an open answer (0: none; default {DEFAULT_BUDGET}, or 0 with '
                             '--library)')
    args = parser.parse_args(argv)
    if args.extra_budget is None:  # a library given by path is fixed unless asked otherwise
        args.extra_budget = 0 if args.library is not None else DEFAULT_BUDGET
    try:
        if args.extra_budget < 0:
            raise DiagnosisError(f'--budget {args.extra_budget}: must be >= 0')
        run(args)
    except (DempathError, ValueError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    return 0
