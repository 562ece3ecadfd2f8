"""Real evaluations for the recalibration: the candidate at a strength on the library's seeds.

Each evaluation runs the candidate on the first ``n`` packing seeds of the signature library
(the same beds the library's baseline ran on; runs stored atomically under ``DIR/runs`` through
the library's picklable task, so a retried or resumed run is never redone) and returns the
statistics *paired* with the library's baseline on the same seeds:
``mu0 + (candidate_s - baseline_s)`` per seed s. Chaos of the packing cancels in the difference.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dempath_diagnose.emulator import CandidateEmulator, Emulator
from dempath_diagnose.errors import DiagnosisError
from dempath_diagnose.library import Library, LibrarySpec, LibraryTask, RunSpec
from dempath_diagnose.recalibrate import SweepLostError
from dempath_diagnose.records import F64, PassRecord
from dempath_diagnose.statistics import Layout, model_statistics

Executor = Callable[[Sequence[Callable[[], Any]], Callable[[int], None]], None]


@dataclass
class RealEvaluator:
    """Callable strength -> (n, k) paired statistics (see the module docstring).

    Attributes:
        scene: The user's scene; library: its signature library; spec: the library's design
        (duration, frames); emulator, layout, cube: what turns a run into statistics;
        cand: the candidate fitted; folder: where runs are stored; executor: Dask or serial;
        seeds: how many library seeds an evaluation uses; cache_dir: packing cache.
    """

    scene: Any
    library: Library
    spec: LibrarySpec
    emulator: Emulator
    layout: Layout
    cube: tuple[float, float, float]
    cand: CandidateEmulator
    folder: Path
    executor: Executor
    seeds: int = 2
    cache_dir: Path | None = None
    retried: list[str] = field(default_factory=list)

    def __call__(self, x: float) -> F64:
        c = self.cand.candidate
        seeds = self.library.seeds()[:self.seeds]
        runs = [RunSpec(f'recal-{c.name}@{x:.6g}', s, c.name, x, c.overrides(x)) for s in seeds]
        paths = [self.folder / 'runs' / r.filename for r in runs]
        tasks = [LibraryTask(self.scene, r, p, self.spec, self.cache_dir)
                 for r, p in zip(runs, paths, strict=True)]
        todo = [t for t, p in zip(tasks, paths, strict=True) if not p.is_file()]
        (self.folder / 'runs').mkdir(parents=True, exist_ok=True)
        try:
            self.executor(todo, lambda _k: None)
        except DiagnosisError:
            raise
        except Exception as err:  # the scheduler or the connection went away
            raise SweepLostError(f'Dask scheduler: lost mid-sweep ({type(err).__name__}: {err}); '
                            'the runs already stored are kept') from err
        out = []
        for i, p in enumerate(paths):
            v = model_statistics(PassRecord.load(p), self.layout, self.cube, True).vector
            out.append(self.emulator.mu0 + v - self.emulator.baseline_runs[i])
        return np.array(out)
