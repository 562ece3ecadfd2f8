"""The per-scene signature library: baseline and candidate passes on shared packing seeds.

Each candidate of the effects library is run at one or two strengths on the *same* seeds as
the baseline (paired runs: they start from the same settled bed, so chaos cancels in the
differences). A run keeps every particle near the surface, subsampled in time, and the tool
force (:class:`~dempath_diagnose.records.PassRecord`), so a new marker layout or time window is
served without new runs.

On disk: ``<root>/<scene>-<key>/`` with ``design.json`` and ``runs/<label>-s<seed>.npz``; the key
hashes the scene's physics (:func:`.simulator.physics_key`) and the design, so a
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
from dempath_diagnose.errors import LibraryError
from dempath_diagnose.library.scene_identity import check_library_scene, scene_identity
from dempath_diagnose.library.simulator import (
    LIBRARY_CANDIDATES,
    Candidate,
    SceneSpec,
    ensure_bed,
    ensure_settled,
    pass_travel_s,
    physics_key,
    run_pass,
    scene_candidates,
    settle_key,
)
from dempath_diagnose.records import PassRecord
from dempath_sim.effects.candidates import (
    EFFECT_FACTORS,
    LOG_FACTORS,
    LOG_SCALE,
    PARAMETER_FACTORS,
)
from dempath_sim.runs.portable import PortableScene, pack_scene
from dempath_sim.runs.rest import REST_TOLERANCE_M

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
        rest_tolerance_m: A run's follow ends once its bed is at rest to this bound [m]
            (``dempath_sim.runs.rest``: every recorded position within it of the full run's;
            0: every run is followed to the end). Not part of the library's key: a library
            built either way is the same model within the bound.
        shared_settle: Runs whose re-settle is the same computation (the baseline and the
            tool-speed candidates of a seed) start from one kept re-settled bed
            (``dempath_sim.runs.shared_settle``): the same records to the bit.
    """

    seeds: tuple[int, ...] = (1001, 1002, 1003)
    candidates: tuple[str, ...] = LIBRARY_CANDIDATES
    duration_s: float = 0.0
    follow_s: float = 0.2
    frame_s: float = 0.02
    keep_depth_m: float = 0.04
    n_strengths: int = 2
    rest_tolerance_m: float = REST_TOLERANCE_M
    shared_settle: bool = True


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


def library_dir(scene: SceneSpec, spec: LibrarySpec, root: Path | None = None,
                backend: str = 'dempath') -> Path:
    """Directory of the library of ``scene`` with ``spec`` on ``backend``.

    The key holds what changes a run's content (the physics, duration, frames, depth kept, the
    engine), not the design: designs with more seeds or candidates add runs to the same folder.
    """
    content: dict[str, Any] = {'duration_s': spec.duration_s, 'follow_s': spec.follow_s,
                               'frame_s': spec.frame_s, 'keep_depth_m': spec.keep_depth_m}
    if backend != 'dempath':  # dempath's own libraries keep their keys
        content['backend'] = backend
    payload = json.dumps({'v': LIBRARY_VERSION, 'content': content}, sort_keys=True)
    key = hashlib.sha256((physics_key(scene) + payload).encode()).hexdigest()[:12]
    return (root or default_cache_root()) / f'{scene.name}-{key}'


def library_state(scene: SceneSpec, spec: LibrarySpec, root: Path | None = None,
                  backend: str = 'dempath') -> tuple[str, int, int]:
    """(``ready`` | ``partial`` | ``missing`` | ``stale``, runs done, runs in the design)."""
    folder = library_dir(scene, spec, root, backend)
    _, runs = design(scene, spec)
    done = sum((folder / 'runs' / r.filename).is_file() for r in runs)
    if done == len(runs):
        return 'ready', done, len(runs)
    if done:
        return 'partial', done, len(runs)
    others = [p for p in folder.parent.glob(f'{scene.name}-*')
              if p != folder and library_backend(p) == backend] \
        if folder.parent.is_dir() else []
    return ('stale' if others else 'missing'), 0, len(runs)


def library_backend(folder: Path) -> str:
    """The engine a library folder was built on (``dempath`` for libraries before there was a
    choice, or when its design cannot be read)."""
    try:
        return str(json.loads((folder / 'design.json').read_text()).get('backend', 'dempath'))
    except (OSError, ValueError, AttributeError):
        return 'dempath'


MAX_TIMED_RUNS = 20  # runs whose recorded wall time is read for an estimate


def recorded_run_s(scene: SceneSpec, spec: LibrarySpec, root: Path | None = None,
                   backend: str = 'dempath') -> tuple[float, int]:
    """Median wall time of one run [s] as recorded in the runs' meta (``drive_wall_s``), and
    how many runs it rests on (0: nothing recorded yet).

    The runs of this library are read first (a partial build), else those of the scene's other
    libraries (a stale one: the physics changed, a run of it costs about the same).
    """
    folder = library_dir(scene, spec, root, backend)
    folders = [folder]
    if folder.parent.is_dir():
        folders += sorted(p for p in folder.parent.glob(f'{scene.name}-*')
                          if p != folder and library_backend(p) == backend)
    for f in folders:
        files = sorted(p for p in (f / 'runs').glob('*.npz') if not p.name.endswith('.tmp.npz'))
        times = [float(PassRecord.read_meta(p).get('drive_wall_s', 0.0))
                 for p in files[:MAX_TIMED_RUNS]]
        times = [t for t in times if t > 0]
        if times:
            return float(statistics.median(times)), len(times)
    return 0.0, 0


Executor = Callable[[Sequence[Callable[[], Any]], Callable[[int, Any], None]], None]


def serial_executor(tasks: Sequence[Callable[[], Any]], done: Callable[[int, Any], None]) -> None:
    """Run tasks one after the other in this process (the engine uses every core); ``done(k,
    value)`` with what each returned."""
    for k, task in enumerate(tasks):
        done(k, task())


@dataclass(frozen=True)
class RunFailure:
    """A run that failed for a reason that would fail it again (bad overrides, an unstable
    set-up): returned by the task, not raised, so that Dask does not retry it; the client
    reports it.

    Attributes:
        label: The run (file name).
        message: The simulator's error line.
    """

    label: str
    message: str


def store_record(path: Path, value: Any) -> RunFailure | None:
    """Save a task's record at ``path`` on this machine (the client); the failure otherwise."""
    if isinstance(value, RunFailure):
        return value
    if not isinstance(value, PassRecord):
        return RunFailure(path.name, f'the task returned {type(value).__name__}, not a record')
    path.parent.mkdir(parents=True, exist_ok=True)
    value.save(path)
    return None


def run_tasks(executor: Executor, tasks: Sequence[LibraryTask], folder: Path,
              on_done: Callable[[int, int], None] | None = None) -> None:
    """Run library tasks and store each record under ``folder`` here, as it arrives.

    Raises:
        LibraryError: Some runs failed; the message names the first (the others are stored).
    """
    failures: list[RunFailure] = []
    finished = [0]

    def done(k: int, value: Any) -> None:
        failure = store_record(folder / tasks[k].run.filename, value)
        if failure is not None:
            failures.append(failure)
        finished[0] += 1
        if on_done is not None:
            on_done(finished[0], len(tasks))

    executor(tasks, done)
    if failures:
        msg = f'{len(failures)} of {len(tasks)} runs failed: {failures[0].label}: ' \
              f'{failures[0].message}'
        raise LibraryError(msg)


def build_library(scene: SceneSpec, spec: LibrarySpec, root: Path | None = None,
                  executor: Executor = serial_executor, cache_dir: Path | None = None,
                  on_done: Callable[[int, int], None] | None = None,
                  worker_cache: Path | None | str = 'same', backend: str = 'dempath') -> Path:
    """Run every missing run of the library (resumable) and return its directory.

    The tasks return their records (and the pours their beds) through the executor; they are
    stored here, on the client: a worker needs no access to the client's folders. The scene's
    tool mesh, packing file and each seed's settled bed travel with the tasks
    (:func:`dempath_sim.runs.portable.pack_scene`).

    Args:
        scene: The user's model (baseline).
        spec: The design.
        root: Library root (``default_cache_root()`` if None).
        executor: Runs the tasks (serial here; :mod:`dempath_diagnose.library.sweep` for Dask).
        cache_dir: The client's packing cache (dempath_sim's default if None).
        on_done: Called with (runs finished, runs to do) after each run.
        worker_cache: The packing cache the tasks use where they run: ``'same'`` (the
            client's, for the serial and local executors), None (each worker's own default:
            workers on other machines).
        backend: ``dempath`` or ``liggghts`` (the engine of the runs).

    Raises:
        LibraryError: Some runs failed (the others are stored).
    """
    folder = library_dir(scene, spec, root, backend)
    (folder / 'runs').mkdir(parents=True, exist_ok=True)
    candidates, runs = design(scene, spec)
    text = json.dumps({
        **scene_identity(scene), 'spec': asdict(spec), 'version': LIBRARY_VERSION,
        'backend': backend, 'candidates': [asdict(c) for c in candidates],
        'runs': [asdict(r) for r in runs]}, indent=1)
    staged = folder / f'design.json.{os.getpid()}.tmp'  # a reader never sees half a design
    staged.write_text(text)
    staged.replace(folder / 'design.json')
    todo = [r for r in runs if not (folder / 'runs' / r.filename).is_file()]
    there = cache_dir if worker_cache == 'same' else worker_cache
    assert not isinstance(there, str)
    seeds = sorted({r.seed for r in todo})
    pours = [LibraryPour(pack_scene(scene), s, there) for s in seeds]
    executor(pours, lambda k, beds: keep_beds(beds, cache_dir))  # one pour per seed first
    portable = {s: pack_scene(scene, (s,), cache_dir) for s in seeds}
    if spec.shared_settle and backend == 'dempath':  # then one re-settle per shared key
        settles = [LibrarySettle(portable[s], s, there) for s in shared_settle_seeds(scene, todo)]
        executor(settles, lambda k, made: None)
    tasks = [LibraryTask(portable[r.seed], r, spec, there, backend) for r in todo]
    tasks.sort(key=LibraryTask.cost, reverse=True)  # longest first: none left alone at the end
    run_tasks(executor, tasks, folder / 'runs', on_done)
    return folder


def shared_settle_seeds(scene: SceneSpec, runs: Sequence[RunSpec]) -> list[int]:
    """The seeds on which two or more of ``runs`` share the baseline's re-settle (its settle
    key): one re-settle there saves the others'."""
    out = []
    for seed in sorted({r.seed for r in runs}):
        key = settle_key(scene, seed, {})
        if sum(settle_key(scene, seed, r.overrides) == key for r in runs if r.seed == seed) > 1:
            out.append(seed)
    return out


@dataclass(frozen=True)
class LibrarySettle:
    """The baseline's re-settled bed of one seed, kept in the packing cache where the task runs
    (a picklable callable; True if made). Runs on other machines that do not find it re-settle
    themselves (the same bed)."""

    scene: PortableScene
    seed: int
    cache_dir: Path | None

    def __call__(self) -> bool:
        return ensure_settled(self.scene.unpack(self.cache_dir), self.seed, {}, self.cache_dir)


def keep_beds(beds: Any, cache_dir: Path | None) -> None:
    """Store the beds a pour task returned (file name -> bytes) in the client's cache."""
    from dempath_sim.runs.bed import default_cache_dir

    for name, data in dict(beds or {}).items():
        path = (cache_dir or default_cache_dir()) / name
        if not path.is_file():
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(name + '.part')
            tmp.write_bytes(data)
            tmp.replace(path)


@dataclass(frozen=True)
class LibraryPour:
    """The settled bed of one seed, poured where the task runs and returned as bytes (a
    picklable callable; file name in the packing cache -> bytes, empty for a shipped bed)."""

    scene: PortableScene
    seed: int
    cache_dir: Path | None

    def __call__(self) -> dict[str, bytes]:
        from dempath_sim.runs.portable import bed_cache_file

        scene = self.scene.unpack(self.cache_dir).with_overrides(seed=self.seed)
        ensure_bed(scene, self.cache_dir)
        found = bed_cache_file(scene, self.cache_dir)
        from dempath_sim.runs.bed import bundled_packing_dir

        if found is None or found.parent == bundled_packing_dir():
            return {}
        return {found.name: found.read_bytes()}


@dataclass(frozen=True)
class LibraryTask:
    """One library run as a picklable callable (for Dask workers): it runs and returns the
    record (or a :class:`RunFailure`); the client stores it.

    Attributes:
        scene: The scene with the files it reads (mesh, packing file, the seed's bed).
        run: The run.
        spec: The library design (duration, frames, depth kept).
        cache_dir: The packing cache where the task runs (None: that machine's default).
        backend: ``dempath`` or ``liggghts``.
    """

    scene: PortableScene
    run: RunSpec
    spec: LibrarySpec
    cache_dir: Path | None
    backend: str = 'dempath'

    def until_s(self) -> float:
        """The simulated time the run covers [s]."""
        return self.spec.duration_s or (pass_travel_s(self.scene.scene, {}) + self.spec.follow_s)

    def cost(self) -> float:
        """Relative cost of the run: its simulated time (at least its own tool travel) over
        its time step, which scales as sqrt(density / Young's modulus) of the particles (the
        Rayleigh step); 0 when the overrides cannot be read (the run itself then says why)."""
        scene = self.scene.scene
        try:
            model = scene.with_overrides(self.run.overrides).physics_model()
            simulated = max(self.until_s(), pass_travel_s(scene, self.run.overrides))
        except (DempathError, ValueError):
            return 0.0
        return simulated * math.sqrt(
            model.particle_youngs_modulus_pa / model.particle_density_kg_m3)

    def __call__(self) -> PassRecord | RunFailure:
        try:
            scene = self.scene.unpack(self.cache_dir)
            native = self.backend == 'dempath'
            return run_pass(scene, self.run.seed, self.run.overrides, until_s=self.until_s(),
                            frame_s=self.spec.frame_s, keep_depth_m=self.spec.keep_depth_m,
                            cache_dir=self.cache_dir, backend=self.backend,
                            rest_tolerance_m=self.spec.rest_tolerance_m if native else 0.0,
                            shared_settle=self.spec.shared_settle and native)
        except DempathError as err:  # deterministic: the same run fails the same way again
            return RunFailure(self.run.filename, ' '.join(str(err).split()))


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
            (:func:`~dempath_diagnose.library.scene_identity.scene_identity`; only the name
            for an older library).
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
        return cls(folder, candidates, runs, records,
                   identity=_identity_of(data)).with_extra_runs()

    @classmethod
    def load_packed(cls, path: Path) -> Library:
        """Read a library packed by :func:`~dempath_diagnose.library.packed.export_library`."""
        from dempath_diagnose.library.packed import load_packed

        data, records = load_packed(path)
        candidates, runs = _design_of(data, path)
        return cls(Path(path), candidates, runs,
                   {r.filename: rec for r, rec in zip(runs, records, strict=True)},
                   region=data['region'], identity=_identity_of(data)).with_extra_runs()

    @property
    def extra_dir(self) -> Path:
        """Where runs added beyond the design are stored: the library folder, or beside a
        packed file (``<file>.extra/``)."""
        return self.folder if self.folder.is_dir() else \
            self.folder.with_name(self.folder.name + '.extra')

    def with_extra_runs(self) -> Library:
        """This library with the stored runs added beyond its design (``extra_runs.json``:
        the adaptive diagnosis's simulations, kept for the next case)."""
        stored = self.extra_dir / 'runs'
        runs = [r for r in read_extra_runs(self.extra_dir)
                if r.filename not in self.records and (stored / r.filename).is_file()]
        if not runs:
            return self
        records = {**self.records,
                   **{r.filename: PassRecord.load(stored / r.filename) for r in runs}}
        return Library(self.folder, self.candidates, [*self.runs, *runs], records, self.region,
                       self.identity)

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


EXTRA_RUNS = 'extra_runs.json'  # runs added beyond the design (the adaptive diagnosis)


def read_extra_runs(folder: Path) -> list[RunSpec]:
    """The runs listed in ``folder/extra_runs.json`` (none when there is no such file)."""
    path = folder / EXTRA_RUNS
    if not path.is_file():
        return []
    try:
        return [RunSpec(**r) for r in json.loads(path.read_text())]
    except (OSError, ValueError, TypeError) as err:
        raise LibraryError(f'{path}: unreadable list of extra runs ({err})') from err


def add_extra_runs(folder: Path, runs: Sequence[RunSpec]) -> None:
    """List ``runs`` in ``folder/extra_runs.json`` (atomically; runs already listed kept once)."""
    known = {r.filename: r for r in read_extra_runs(folder)}
    known.update({r.filename: r for r in runs})
    folder.mkdir(parents=True, exist_ok=True)
    tmp = folder / (EXTRA_RUNS + '.tmp')
    tmp.write_text(json.dumps([asdict(r) for r in known.values()], indent=1))
    tmp.replace(folder / EXTRA_RUNS)


def extend_library(library: Library, scene: SceneSpec, spec: LibrarySpec,
                   additions: Sequence[tuple[str, float]], n_seeds: int,
                   executor: Executor = serial_executor, cache_dir: Path | None = None,
                   worker_cache: Path | None | str = 'same',
                   backend: str = 'dempath') -> Library:
    """Run candidates at new strengths on the library's first ``n_seeds`` seeds (paired with its
    baseline runs), store them with the library for the next case, return the grown library.

    Args:
        library: The library.
        scene: Its scene (the baseline).
        spec: Its design (duration, frames, depth kept).
        additions: (candidate name, strength) pairs to run.
        n_seeds: Seeds per strength (the library's first ones).
        executor, cache_dir, worker_cache, backend: As for :func:`build_library`.

    Raises:
        LibraryError: A candidate is not in the library, or some runs failed.
    """
    cands = {c.name: c for c in library.candidates}
    unknown = [name for name, _ in additions if name not in cands]
    if unknown:
        raise LibraryError(f'{library.folder}: no candidate {unknown[0]!r} in the library')
    runs = [RunSpec(f'{name}@{x:.6g}', s, name, float(x), cands[name].overrides(float(x)))
            for name, x in additions for s in library.seeds()[:n_seeds]]
    folder = library.extra_dir
    todo = [r for r in runs if not (folder / 'runs' / r.filename).is_file()]
    there = cache_dir if worker_cache == 'same' else worker_cache
    assert not isinstance(there, str)
    portable = {s: pack_scene(scene, (s,), cache_dir) for s in {r.seed for r in todo}}
    run_tasks(executor, [LibraryTask(portable[r.seed], r, spec, there, backend) for r in todo],
              folder / 'runs')
    add_extra_runs(folder, runs)
    return library.with_extra_runs()


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
