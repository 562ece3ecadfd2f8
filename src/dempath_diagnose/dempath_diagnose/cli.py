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

from dempath.errors import DempathError
from dempath_diagnose.diagnose import CaseGeometry, Diagnosis, diagnose
from dempath_diagnose.emulator import Allowance
from dempath_diagnose.errors import DiagnosisError, MeasurementError
from dempath_diagnose.library import (
    Library,
    LibrarySpec,
    build_library,
    covering_duration,
    library_dir,
    library_state,
)
from dempath_diagnose.measure import load_force, load_tracks
from dempath_diagnose.records import Measurement
from dempath_diagnose.simulate import (
    LIBRARY_CANDIDATES,
    SceneSpec,
    load_scene,
    pass_travel_s,
    tool_geometry,
)

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
    p.add_argument('--seeds', default='1001,1002,1003,1004', help='library packing seeds')
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
    return p


def _origin(text: str) -> tuple[float, float, float]:
    try:
        values = [float(v) for v in text.split(',')]
    except ValueError as err:
        raise DiagnosisError(f'--origin {text!r}: expected X,Y,Z in metres') from err
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise DiagnosisError(f'--origin {text!r}: expected three finite numbers X,Y,Z')
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
    """Load the library, building (or completing) it first when needed, with progress."""
    state, done, total = library_state(scene, spec, args.library_root)
    if state != 'ready':
        why = {'missing': 'no signature library', 'stale': 'the library is stale (the scene '
               'changed)', 'partial': f'the library is partial ({done} of {total} runs)'}[state]
        print(f'{scene.name}: {why}; running {total - done} simulations (the progress bar '
              'shows the time left)', file=sys.stderr)
        _build(args, scene, spec, total - done)
    return Library.load(library_dir(scene, spec, args.library_root))


def _build(args: argparse.Namespace, scene: SceneSpec, spec: LibrarySpec, todo: int) -> None:
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from dempath_diagnose.library import serial_executor

    bar = Progress(TextColumn('library'), BarColumn(), MofNCompleteColumn(),
                   TimeElapsedColumn(), TextColumn('ETA'), TimeRemainingColumn(),
                   console=None)
    with bar:
        task = bar.add_task('library', total=todo)

        def on_done(n: int, _total: int) -> None:
            bar.update(task, completed=n)

        if args.serial:
            build_library(scene, spec, args.library_root, serial_executor, args.packing_cache,
                          on_done)
            return
        from dempath_diagnose.sweep import DaskSweep

        with DaskSweep(args.scheduler, args.workers) as sweep:
            build_library(scene, spec, args.library_root, sweep.run, args.packing_cache,
                          on_done)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """The whole command; returns diagnosis.json's content."""
    t0 = time.monotonic()
    scene, _spec, library, allowance, result = diagnosis_of(args)
    result.wall_s = time.monotonic() - t0
    from dempath_diagnose.report import print_ranking, write_outputs

    data = write_outputs(result, args.out, {'scene': scene.name, 'library': str(library.folder),
                                            'allowance': vars(allowance)})
    print_ranking(data)
    return data


def diagnosis_of(args: argparse.Namespace,
                 ) -> tuple[SceneSpec, LibrarySpec, Library, Allowance, Diagnosis]:
    """Scene, library design, library (built when needed), allowance and diagnosis of the parsed
    arguments (what ``dempath recalibrate`` builds on)."""
    origin = _origin(args.origin)
    scene = load_scene(args.scene)
    meas = load_tracks(args.measured, origin)
    for marker, problem in sorted(meas.problems.items()):
        print(f'warning: {args.measured}: marker {marker}: {problem} (left out)', file=sys.stderr)
    if args.force is not None:
        t, f = load_force(args.force)
        meas = replace(meas, force_times=t, force=f)
    spec = library_spec(args, scene, meas)
    library = ensure_library(args, scene, spec)
    tool_x, half_width, cube = tool_geometry(scene)
    allowance = Allowance(args.noise, args.discrepancy, args.discrepancy_rel,
                          args.discrepancy_force)
    result = diagnose(meas, library, CaseGeometry(tool_x, half_width, cube), allowance,
                      args.windows, str(args.force))
    result.simulations = len(library.runs)
    return scene, spec, library, allowance, result


def diagnose_main(argv: list[str] | None = None) -> int:
    """``dempath diagnose``: where the model fails against a measured pass, what it misses.

    Returns 0, or 1 after one ``error: <input>: <problem>`` line on bad input.
    """
    args = _parser().parse_args(argv)
    try:
        run(args)
    except (DempathError, ValueError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    return 0
