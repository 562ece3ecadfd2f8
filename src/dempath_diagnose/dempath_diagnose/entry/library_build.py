"""The signature library a diagnosis needs: read it, or build (or complete) it first.

Before a library is built, one line says why (missing, stale, partial), how many simulations
and about how long; a progress bar follows the runs. The runs go through Dask (a local cluster
or ``scheduler``) or, with ``serial``, run here one after another.
"""

from __future__ import annotations

import math
import sys
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from dempath_diagnose.entry.requests import DiagnoseRequest
from dempath_diagnose.library.simulator import SceneSpec
from dempath_diagnose.library.store import (
    Library,
    LibrarySpec,
    build_library,
    library_dir,
    library_state,
    recorded_run_s,
    serial_executor,
)


def ensure_library(request: DiagnoseRequest, scene: SceneSpec, spec: LibrarySpec) -> Library:
    """Load the library, building (or completing) it first when needed, saying why and how long
    it will take, with a progress bar."""
    if request.library is not None:
        return Library.load(request.library)
    root, backend = request.library_root, request.backend
    state, done, total = library_state(scene, spec, root, backend)
    if state != 'ready':
        width = 1 if request.serial else max(1, request.workers or 2)
        per_run, timed = recorded_run_s(scene, spec, root, backend)
        print(library_notice(scene.name, state, done, total, per_run, timed, width),
              file=sys.stderr)
        _build(request, scene, spec, total - done, per_run)
    return Library.load(library_dir(scene, spec, root, backend))


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


def _build(request: DiagnoseRequest, scene: SceneSpec, spec: LibrarySpec, todo: int,
           per_run_s: float) -> None:
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

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

        if request.serial:
            build_library(scene, spec, request.library_root, serial_executor,
                          request.packing_cache, on_done, backend=request.backend)
            return
        from dempath_diagnose.library.sweep import DaskSweep

        with DaskSweep(request.scheduler, request.workers) as sweep:
            build_library(scene, spec, request.library_root, sweep.run, request.packing_cache,
                          on_done, worker_cache=None if sweep.remote else 'same',
                          backend=request.backend)


def library_executor(request: DiagnoseRequest, stack: ExitStack,
                     ) -> tuple[Any, Path | None | str]:
    """(executor, worker packing cache) for runs beyond the library: serial, or a Dask cluster
    entered on ``stack`` only when something runs."""
    if request.serial:
        return serial_executor, 'same'
    from dempath_diagnose.library.sweep import DaskSweep

    sweep = None

    def lazy(tasks: Any, done: Any) -> None:
        nonlocal sweep
        if sweep is None:
            sweep = stack.enter_context(DaskSweep(request.scheduler, request.workers))
        sweep.run(tasks, done)

    return lazy, None if request.scheduler else 'same'
