"""Real evaluations for the recalibration: the candidate at strengths on the library's seeds.

Each evaluation runs the candidate (and the parameters refitted beside it) on the first ``n``
packing seeds of the signature library (the same beds the library's baseline ran on; the
library's picklable task returns each record through the executor and it is stored atomically
here under ``DIR/runs``, so a resumed run is never redone and a worker needs no access to DIR)
and returns the statistics *paired* with the library's baseline on the same
seeds: ``mu0 + (candidate_s - baseline_s)`` per seed s. Chaos of the packing cancels in the
difference.

:func:`dask_executor` runs the tasks on a Dask client and tells a lost scheduler (futures
cancelled, the connection closed) from a failed run: the first raises
:class:`.loop.SweepLostError` (the loop stops, what is stored is kept),
the second :class:`~dempath_diagnose.errors.ClusterError` (that candidate is scored as failed).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dempath_diagnose.decision.emulator import CandidateEmulator, Emulator
from dempath_diagnose.decision.statistics import Layout, model_statistics
from dempath_diagnose.errors import ClusterError, DiagnosisError, LibraryError
from dempath_diagnose.library.store import Library, LibrarySpec, LibraryTask, RunSpec, run_tasks
from dempath_diagnose.recalibration.loop import SweepLostError
from dempath_diagnose.records import F64, PassRecord
from dempath_sim.runs.portable import pack_scene

Executor = Callable[[Sequence[Callable[[], Any]], Callable[[int, Any], None]], None]
RETRIES = 2  # attempts after a worker died (a failed run fails the same way again)


def dask_executor(client: Any) -> Executor:
    """An executor on a Dask ``client`` that raises SweepLostError when the scheduler goes."""

    def run(tasks: Sequence[Callable[[], Any]], done: Callable[[int, Any], None]) -> None:
        from distributed import as_completed

        if not tasks:
            return
        try:
            futures = {client.submit(t, retries=RETRIES, pure=False): k
                       for k, t in enumerate(tasks)}
            failed = []
            for future in as_completed(futures):  # type: ignore[no-untyped-call]
                if future.status == 'cancelled':
                    raise SweepLostError(f'Dask scheduler {client.scheduler.address}: lost '
                                         'mid-sweep; the runs already stored are kept, a '
                                         'rerun with the same --out resumes')
                if future.status == 'error':
                    failed.append(f'{future.exception()}')
                else:
                    done(futures[future], future.result())
        except (OSError, TimeoutError) as err:
            msg = (f'Dask scheduler: lost mid-sweep ({type(err).__name__}: {err}); the runs '
                   'already stored are kept, a rerun with the same --out resumes')
            raise SweepLostError(msg) from err
        if failed:
            raise ClusterError(f'{len(failed)} of {len(tasks)} runs failed: {failed[0]}')

    return run


@dataclass
class RealEvaluator:
    """Callable strengths (n,) -> (S, k) paired statistics (see the module docstring).

    Attributes:
        scene: The user's scene; library: its signature library; spec: the library's design
        (duration, frames); emulator, layout, cube: what turns a run into statistics;
        cands: the candidate and the parameters refitted beside it; folder: where runs are
        stored (``folder/runs``); executor: Dask or serial; seeds: how many library seeds an
        evaluation uses; cache_dir: packing cache.
        runs: Run files of each evaluation, by strengths (for the paper's metrics after).
    """

    scene: Any
    library: Library
    spec: LibrarySpec
    emulator: Emulator
    layout: Layout
    cube: tuple[float, float, float]
    cands: list[CandidateEmulator]
    folder: Path
    executor: Executor
    seeds: int = 2
    cache_dir: Path | None = None
    worker_cache: Path | None | str = 'same'
    backend: str = 'dempath'
    runs: dict[tuple[float, ...], list[Path]] = field(default_factory=dict)

    def run_specs(self, x: F64) -> list[RunSpec]:
        """The runs of one evaluation at strengths ``x``."""
        overrides: dict[str, float] = {}
        for c, v in zip(self.cands, x, strict=True):
            overrides.update(c.candidate.overrides(float(v)))
        label = 'recal-' + '+'.join(f'{c.candidate.name}@{v:.6g}'
                                    for c, v in zip(self.cands, x, strict=True))
        return [RunSpec(label, s, self.cands[0].candidate.name, float(x[0]), overrides)
                for s in self.library.seeds()[:self.seeds]]

    def __call__(self, x: F64) -> F64:
        runs = self.run_specs(x)
        paths = [self.folder / 'runs' / r.filename for r in runs]
        there = self.cache_dir if self.worker_cache == 'same' else self.worker_cache
        assert not isinstance(there, str)
        portable = {s: pack_scene(self.scene, (s,), self.cache_dir)
                    for s in {r.seed for r in runs}}
        todo = [LibraryTask(portable[r.seed], r, self.spec, there, self.backend)
                for r, p in zip(runs, paths, strict=True) if not p.is_file()]
        try:
            run_tasks(self.executor, todo, self.folder / 'runs')
        except LibraryError as err:
            raise ClusterError(str(err)) from err
        missing = [p.name for p in paths if not p.is_file()]
        if missing:
            raise DiagnosisError(f'{missing[0]}: the run was not stored')
        self.runs[tuple(float(v) for v in x)] = paths
        out = []
        for i, p in enumerate(paths):
            v = model_statistics(PassRecord.load(p), self.layout, self.cube, True).vector
            out.append(self.emulator.mu0 + v - self.emulator.baseline_runs[i])
        return np.array(out)

    def baseline_records(self) -> list[tuple[str, PassRecord]]:
        """(name, record) of the library's baseline runs on the seeds an evaluation uses (the
        paired 'before'), from the loaded library: a packed library has no run files."""
        ((_, files),) = self.library.model_runs('').items()
        return [(Path(f).stem, self.library.records[f]) for f in files[:self.seeds]]
