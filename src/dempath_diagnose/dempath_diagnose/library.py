"""The per-scene signature library: baseline and candidate passes on shared packing seeds.

Each candidate of the effects library is run at one or two strengths on the *same* seeds as
the baseline (paired runs: they start from the same settled bed, so chaos cancels in the
differences). A run keeps every particle near the surface, subsampled in time, and the tool
force (:class:`~dempath_diagnose.records.PassRecord`), so a new marker layout or time window is
served without new runs.

On disk: ``<root>/<scene>-<key>/`` with ``design.json`` and ``runs/<label>-s<seed>.npz``; the key
hashes the scene's physics (:func:`~dempath_diagnose.simulate.physics_key`) and the design, so a
changed scene gets a new library (the old one is reported as stale). Every finished run is saved
at once (atomically): an interrupted build resumes where it stopped.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import statistics
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from dempath.errors import DempathError
from dempath_diagnose.admission import check_library_scene, scene_identity
from dempath_diagnose.errors import LibraryError
from dempath_diagnose.records import PassRecord
from dempath_diagnose.simulate import (
    LIBRARY_CANDIDATES,
    Candidate,
    SceneSpec,
    ensure_bed,
    pass_travel_s,
    physics_key,
    run_pass,
    scene_candidates,
)
from dempath_sim.effects.candidates import (
    EFFECT_FACTORS,
    LOG_FACTORS,
    LOG_SCALE,
    PARAMETER_FACTORS,
)

logger = logging.getLogger(__name__)

LIBRARY_VERSION = 2  # bump when what a run records changes (2: effect runs re-settle the bed)

COVER_STEP_S = 0.5  # longer measurements get libraries in steps of this [s]


def covering_duration(travel_s: float, end_s: float, follow_s: float = 0.2) -> float:
    """The library duration for a measurement ending at ``end_s``: the baseline's travel plus
    ``follow_s``, or longer in COVER_STEP_S steps (so that libraries are shared by cases)."""
    base = round(travel_s + follow_s, 3)
    if end_s <= base + 0.02:
        return base
    return math.ceil(end_s / COVER_STEP_S - 1e-9) * COVER_STEP_S


def default_cache_root() -> Path:
    """``$DEMPATH_CACHE_DIR/diagnose`` or ``~/.cache/dempath/diagnose``."""
    root = os.environ.get('DEMPATH_CACHE_DIR')
    return (Path(root) if root else Path.home() / '.cache' / 'dempath') / 'diagnose'


@dataclass(frozen=True)
class LibrarySpec:
    """What the library holds.

    Attributes:
        seeds: Packing seeds shared by every model (never the seeds of a case to diagnose).
        candidates: Effect names to include.
        duration_s: Every run covers [0, duration_s] (the bed is followed after the tool stops
            for what remains); 0: the baseline's travel plus ``follow_s``.
        follow_s: Time followed after the tool stops when ``duration_s`` is 0 [s].
        frame_s: Interval of the kept frames [s].
        keep_depth_m: Particles starting this far below the surface or higher are kept [m].
        n_strengths: Strengths per effect that is off (1 or 2); parameters get two.
    """

    seeds: tuple[int, ...] = (1001, 1002, 1003)
    candidates: tuple[str, ...] = LIBRARY_CANDIDATES
    duration_s: float = 0.0
    follow_s: float = 0.2
    frame_s: float = 0.02
    keep_depth_m: float = 0.04
    n_strengths: int = 2


@dataclass(frozen=True)
class RunSpec:
    """One library run: a model (baseline or candidate at a strength) on one seed."""

    label: str
    seed: int
    candidate: str = ''
    strength: float = 0.0
    overrides: dict[str, float] = field(default_factory=dict)

    @property
    def filename(self) -> str:
        """File name of the stored record."""
        return f'{self.label}-s{self.seed}.npz'


def strengths(candidate: Candidate, n: int) -> tuple[float, ...]:
    """The strengths a candidate is run at (inside its physical range).

    An effect that is off: ``n`` strengths from its default up. A parameter that is on: one
    below and one above its value whatever ``n`` (it may be off in either direction).
    """
    if candidate.kind == 'effect':
        from dempath_sim.effects import get_effect

        base = get_effect(candidate.name).parameter(candidate.parameter).default
        factors = EFFECT_FACTORS[:n]
    else:
        base = candidate.current
        factors = LOG_FACTORS if candidate.name in LOG_SCALE else PARAMETER_FACTORS
    values = [min(max(base * f, candidate.low), candidate.high) for f in factors]
    return tuple(float(v) for v in values if v != candidate.current)


def design(scene: SceneSpec, spec: LibrarySpec) -> tuple[list[Candidate], list[RunSpec]]:
    """The candidates and every run of the library, baseline first, seed-major."""
    candidates = scene_candidates(scene, spec.candidates)
    runs = [RunSpec('baseline', s) for s in spec.seeds]
    for c in candidates:
        for x in strengths(c, spec.n_strengths):
            runs += [RunSpec(f'{c.name}@{x:.6g}', s, c.name, x, c.overrides(x))
                     for s in spec.seeds]
    return candidates, runs


def library_dir(scene: SceneSpec, spec: LibrarySpec, root: Path | None = None) -> Path:
    """Directory of the library of ``scene`` with ``spec``.

    The key holds what changes a run's content (the physics, duration, frames, depth kept), not
    the design: designs with more seeds or candidates add runs to the same folder.
    """
    content = {'duration_s': spec.duration_s, 'follow_s': spec.follow_s,
               'frame_s': spec.frame_s, 'keep_depth_m': spec.keep_depth_m}
    payload = json.dumps({'v': LIBRARY_VERSION, 'content': content}, sort_keys=True)
    key = hashlib.sha256((physics_key(scene) + payload).encode()).hexdigest()[:12]
    return (root or default_cache_root()) / f'{scene.name}-{key}'


def library_state(scene: SceneSpec, spec: LibrarySpec, root: Path | None = None,
                  ) -> tuple[str, int, int]:
    """(``ready`` | ``partial`` | ``missing`` | ``stale``, runs done, runs in the design)."""
    folder = library_dir(scene, spec, root)
    _, runs = design(scene, spec)
    done = sum((folder / 'runs' / r.filename).is_file() for r in runs)
    if done == len(runs):
        return 'ready', done, len(runs)
    if done:
        return 'partial', done, len(runs)
    others = [p for p in folder.parent.glob(f'{scene.name}-*') if p != folder] \
        if folder.parent.is_dir() else []
    return ('stale' if others else 'missing'), 0, len(runs)


MAX_TIMED_RUNS = 20  # runs whose recorded wall time is read for an estimate


def recorded_run_s(scene: SceneSpec, spec: LibrarySpec, root: Path | None = None,
                   ) -> tuple[float, int]:
    """Median wall time of one run [s] as recorded in the runs' meta (``drive_wall_s``), and
    how many runs it rests on (0: nothing recorded yet).

    The runs of this library are read first (a partial build), else those of the scene's other
    libraries (a stale one: the physics changed, a run of it costs about the same).
    """
    folder = library_dir(scene, spec, root)
    folders = [folder]
    if folder.parent.is_dir():
        folders += sorted(p for p in folder.parent.glob(f'{scene.name}-*') if p != folder)
    for f in folders:
        files = sorted(p for p in (f / 'runs').glob('*.npz') if not p.name.endswith('.tmp.npz'))
        times = [float(PassRecord.read_meta(p).get('drive_wall_s', 0.0))
                 for p in files[:MAX_TIMED_RUNS]]
        times = [t for t in times if t > 0]
        if times:
            return float(statistics.median(times)), len(times)
    return 0.0, 0


Executor = Callable[[Sequence[Callable[[], Any]], Callable[[int], None]], None]


def serial_executor(tasks: Sequence[Callable[[], Any]], done: Callable[[int], None]) -> None:
    """Run tasks one after the other in this process (the engine uses every core)."""
    for k, task in enumerate(tasks):
        task()
        done(k)


def build_library(scene: SceneSpec, spec: LibrarySpec, root: Path | None = None,
                  executor: Executor = serial_executor, cache_dir: Path | None = None,
                  on_done: Callable[[int, int], None] | None = None) -> Path:
    """Run every missing run of the library (resumable) and return its directory.

    Args:
        scene: The user's model (baseline).
        spec: The design.
        root: Library root (``default_cache_root()`` if None).
        executor: Runs the tasks (serial here; :mod:`dempath_diagnose.sweep` for Dask).
        cache_dir: Packing cache (dempath_sim's default if None).
        on_done: Called with (runs finished, runs to do) after each run.
    """
    folder = library_dir(scene, spec, root)
    (folder / 'runs').mkdir(parents=True, exist_ok=True)
    candidates, runs = design(scene, spec)
    (folder / 'design.json').write_text(json.dumps({
        **scene_identity(scene), 'spec': asdict(spec), 'version': LIBRARY_VERSION,
        'candidates': [asdict(c) for c in candidates],
        'runs': [asdict(r) for r in runs]}, indent=1))
    todo = [r for r in runs if not (folder / 'runs' / r.filename).is_file()]
    pours = [LibraryPour(scene, s, cache_dir) for s in sorted({r.seed for r in todo})]
    executor(pours, lambda _: None)  # one bed per seed first: no two workers pour the same
    tasks = [LibraryTask(scene, r, folder / 'runs' / r.filename, spec, cache_dir) for r in todo]
    tasks.sort(key=LibraryTask.cost, reverse=True)  # longest first: none left alone at the end
    finished = [0]

    def done(_: int) -> None:
        finished[0] += 1
        if on_done is not None:
            on_done(finished[0], len(tasks))

    executor(tasks, done)
    return folder


@dataclass(frozen=True)
class LibraryPour:
    """The settled bed of one seed, poured into the packing cache (a picklable callable)."""

    scene: Any
    seed: int
    cache_dir: Path | None

    def __call__(self) -> bool:
        return ensure_bed(self.scene.with_overrides(seed=self.seed), self.cache_dir)


@dataclass(frozen=True)
class LibraryTask:
    """One library run as a picklable callable (for Dask workers): run it and store it."""

    scene: Any
    run: RunSpec
    path: Path
    spec: LibrarySpec
    cache_dir: Path | None

    def until_s(self) -> float:
        """The simulated time the run covers [s]."""
        return self.spec.duration_s or (pass_travel_s(self.scene, {}) + self.spec.follow_s)

    def cost(self) -> float:
        """Relative cost of the run: its simulated time (at least its own tool travel) over
        its time step, which scales as sqrt(density / Young's modulus) of the particles (the
        Rayleigh step); 0 when the overrides cannot be read (the run itself then says why)."""
        try:
            model = self.scene.with_overrides(self.run.overrides).physics_model()
            simulated = max(self.until_s(), pass_travel_s(self.scene, self.run.overrides))
        except (DempathError, ValueError):
            return 0.0
        return simulated * math.sqrt(
            model.particle_youngs_modulus_pa / model.particle_density_kg_m3)

    def __call__(self) -> str:
        if self.path.is_file():  # a retried task whose first attempt finished
            return str(self.path)
        until = self.until_s()
        record = run_pass(self.scene, self.run.seed, self.run.overrides,
                          until_s=until, frame_s=self.spec.frame_s,
                          keep_depth_m=self.spec.keep_depth_m, cache_dir=self.cache_dir)
        record.save(self.path)
        return str(self.path)


@dataclass
class Library:
    """A built library, read from its folder or from a packed file (:mod:`.packed`).

    Attributes:
        folder: Its directory (or the packed file).
        candidates: The candidates.
        runs: Every run of the design.
        records: Loaded records by file name.
        region: For a packed library, the marker region it was packed for (None: every
            particle near the surface is there).
        identity: The scene it was built for: name, physics key, a key per part
            (:func:`~dempath_diagnose.admission.scene_identity`; only the name for an older
            library).
    """

    folder: Path
    candidates: list[Candidate]
    runs: list[RunSpec]
    records: dict[str, PassRecord]
    region: dict[str, Any] | None = None
    identity: dict[str, Any] = field(default_factory=dict)

    def check_scene(self, scene: SceneSpec) -> None:
        """Refuse this library for another scene or other physics (LibraryError, one line)."""
        check_library_scene(self.folder, self.identity, scene)

    @classmethod
    def load(cls, folder: Path) -> Library:
        """Read a library folder or a packed library file; LibraryError when the design or a run
        is missing."""
        folder = Path(folder)
        if folder.is_file():
            return cls.load_packed(folder)
        try:
            data = json.loads((folder / 'design.json').read_text())
        except (OSError, ValueError) as err:
            raise LibraryError(f'{folder}: no readable library design ({err})') from err
        candidates, runs = _design_of(data, folder)
        missing = [r.filename for r in runs if not (folder / 'runs' / r.filename).is_file()]
        if missing:
            raise LibraryError(f'{folder}: {len(missing)} runs missing (e.g. {missing[0]})')
        records = {r.filename: PassRecord.load(folder / 'runs' / r.filename) for r in runs}
        return cls(folder, candidates, runs, records, identity=_identity_of(data))

    @classmethod
    def load_packed(cls, path: Path) -> Library:
        """Read a library packed by :func:`~dempath_diagnose.packed.export_library`."""
        from dempath_diagnose.packed import load_packed

        data, records = load_packed(path)
        candidates, runs = _design_of(data, path)
        return cls(Path(path), candidates, runs,
                   {r.filename: rec for r, rec in zip(runs, records, strict=True)},
                   region=data['region'], identity=_identity_of(data))

    def seeds(self) -> list[int]:
        """The packing seeds, in design order."""
        return sorted({r.seed for r in self.runs})

    def model_runs(self, candidate: str = '') -> dict[float, list[str]]:
        """Run files of the baseline ('') or of one candidate: strength -> files by seed."""
        out: dict[float, list[str]] = {}
        for r in sorted(self.runs, key=lambda r: r.seed):
            if r.candidate == candidate:
                out.setdefault(r.strength, []).append(r.filename)
        return out


def _design_of(data: dict[str, Any], where: Path) -> tuple[list[Candidate], list[RunSpec]]:
    """Candidates and runs of a stored design (design.json or a packed library).

    Raises:
        LibraryError: A design of another layout (an older dempath's), naming what is missing.
    """
    try:
        candidates = [Candidate(**{**c, 'linked': tuple(tuple(x) for x in c['linked'])})
                      for c in data['candidates']]
        return candidates, [RunSpec(**r) for r in data['runs']]
    except (KeyError, TypeError, ValueError) as err:
        msg = (f'{where}: a library design of another layout ({type(err).__name__}: {err}); '
               'rebuild the library with this dempath')
        raise LibraryError(msg) from None


def _identity_of(data: dict[str, Any]) -> dict[str, Any]:
    """The scene identity a stored design carries (empty for a library that has none)."""
    return {k: data[k] for k in ('scene', 'physics_key', 'parts') if k in data}
