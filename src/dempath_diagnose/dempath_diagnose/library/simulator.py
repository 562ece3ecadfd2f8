"""The one door to dempath_sim: scenes, the effects library as candidates, and one model pass.

Everything the diagnosis needs from the simulator goes through this module, so that a change of
dempath_sim's layout (issue 11) is ported here and nowhere else. A pass starts from the settled
bed of the *baseline* scene for its seed (:func:`ensure_bed`; dempath_sim's ``fill.physics:
scene``), re-settled against the tool with the run's own physics, so that runs that differ only
in the physics share the packing and chaos cancels in paired differences. The whole bed is
recorded every ``frame_s`` and the particles near the surface are kept
(:class:`~dempath_diagnose.records.PassRecord`), so any marker layout and time window can be
served later without new runs.

Assumptions: a candidate's strength is the value of its main parameter; the other parameters of
the effect (dynamic friction) are scaled with it in the scene's proportion.
"""

from __future__ import annotations

import hashlib
import json
import logging
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath.errors import DempathError
from dempath_diagnose.errors import DiagnosisError
from dempath_diagnose.records import PassRecord
from dempath_sim.effects.candidates import CANDIDATES as LIBRARY_CANDIDATES
from dempath_sim.effects.candidates import LINKED, MAIN_PARAMETER

logger = logging.getLogger(__name__)

SceneSpec = Any  # dempath_sim.scene_spec.SceneSpec (kept opaque outside this module)
# The engine's overlap stop is a safety heuristic that kills soft cohesive or rolling runs that
# finish in LIGGGHTS (issue 12); sweeps raise it to this fraction of the radius.
SWEEP_OVERLAP_LIMIT = 0.95


@dataclass(frozen=True)
class Candidate:
    """One candidate explanation: an effect the scene has off, or a parameter that may be off.

    Attributes:
        name: Effect name in the effects library (``cohesion``, ``tool_speed``...).
        kind: ``effect`` (switched off in the scene) or ``parameter`` (on, value may be off).
        parameter: The main parameter; its value is the candidate's strength.
        unit: SI unit of the strength.
        low, high: Physical range of the strength (the effect's ParameterSpec).
        current: The strength in the scene (for an effect that is off: its 'absent' value 0).
        linked: Other parameters of the effect and their scene values (scaled with the strength).
    """

    name: str
    kind: str
    parameter: str
    unit: str
    low: float
    high: float
    current: float
    linked: tuple[tuple[str, float], ...] = ()

    def overrides(self, strength: float) -> dict[str, float]:
        """Scene overrides ``{'effect.parameter': value}`` that set the strength."""
        out = {f'{self.name}.{self.parameter}': float(strength)}
        scale = strength / self.current if self.current else 1.0
        for name, value in self.linked:
            out[f'{self.name}.{name}'] = float(value * scale)
        return out


def load_scene(text: str) -> SceneSpec:
    """A scene file or a shipped scene name (``builtin:tiny``); SceneError otherwise."""
    from dempath_sim.scene import resolve_scene

    return resolve_scene(text)


def scene_candidates(scene: SceneSpec, names: tuple[str, ...] = LIBRARY_CANDIDATES,
                     ) -> list[Candidate]:
    """The candidates of ``scene`` among ``names`` (unknown names raise DiagnosisError)."""
    from dempath_sim.effects import all_effects

    effects = all_effects()
    out = []
    for name in names:
        if name not in effects:
            msg = f'{name}: not an effect of the library; known: {", ".join(effects)}'
            raise DiagnosisError(msg)
        spec = effects[name].parameter(MAIN_PARAMETER[name])
        setting = scene.effects[name]
        enabled = bool(setting.enabled)
        current = float(setting.values[spec.name]) if enabled else 0.0
        linked = tuple((p, float(setting.values[p])) for p in LINKED.get(spec.name, ())
                       if enabled and p in setting.values)
        out.append(Candidate(name, 'parameter' if enabled else 'effect', spec.name, spec.unit,
                             spec.low, spec.high, current, linked))
    return out


def physics_key(scene: SceneSpec) -> str:
    """Hash (16 hex) of everything in a scene that changes its passes (not its name or seed).

    Files the scene names (the tool mesh, a packing) count by their content, not their path, so
    the same scene read from another clone or install keeps its key (and its library).
    """
    text = json.dumps(scene_parts(scene), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def scene_parts(scene: SceneSpec) -> dict[str, Any]:
    """The parts of a scene that change its passes (the record :func:`physics_key` hashes):
    its dict without name, description, seed, source and output, files by their content."""
    data: dict[str, Any] = scene.to_dict()
    for key in ('name', 'description', 'seed', 'source', 'output'):
        data.pop(key, None)
    if data.get('markers', {}).get('pick') == 'exposed':
        del data['markers']['pick']  # the default rule: keys made before the option stay valid
    data['tool']['mesh'] = _file_digest(scene.tool.mesh)
    if scene.fill.packing is not None:
        data['fill']['packing'] = _file_digest(scene.fill.packing)
    return data


def _file_digest(path: Any) -> str:
    """sha256 of a file's bytes (its name when it cannot be read: the run will say why)."""
    try:
        return hashlib.sha256(Path(str(path)).read_bytes()).hexdigest()
    except OSError:
        return str(path)


def travel_time_s(scene: SceneSpec, speed_scale: float = 1.0) -> float:
    """Sim time [s] the tool needs for its travel (at ``speed_scale`` x the scene's profile)."""
    from dempath_sim.scene.profiles import ToolPath

    tool = scene.tool
    path = ToolPath(tool.profile.scaled(speed_scale), (0.0, 0.0, 0.0), tool.profile_offset_m)
    return float(path.time_to_travel(tool.travel_m))


def _sweep_scene(scene: SceneSpec) -> SceneSpec:
    """``scene`` with the overlap stop raised to SWEEP_OVERLAP_LIMIT (not part of the packing)."""
    limit = max(float(scene.sim.max_overlap_fraction), SWEEP_OVERLAP_LIMIT)
    return replace(scene, sim=replace(scene.sim, max_overlap_fraction=limit))


def pass_travel_s(scene: SceneSpec, overrides: dict[str, float]) -> float:
    """Time [s] the tool travels in ``scene`` with ``overrides`` (its speed scale applied)."""
    try:
        model = scene.with_overrides(overrides).physics_model()
    except (DempathError, ValueError) as err:
        raise DiagnosisError(f'{scene.name} {overrides}: {err}') from err
    return travel_time_s(scene, float(model.speed_scale))


def pass_scene(scene: SceneSpec, seed: int, overrides: dict[str, float],
               frame_s: float = 0.02) -> SceneSpec:
    """The scene a library pass of ``scene`` with ``overrides`` on ``seed`` runs (the sweep's
    overlap limit, whole-bed frames every ``frame_s``, no candidate cubes).

    Raises:
        DiagnosisError: The overrides cannot be applied.
    """
    try:
        base = _sweep_scene(scene.with_overrides(seed=seed))
        output = replace(base.output, snapshot_interval_s=frame_s, candidates=False)
        base = replace(base, output=output)
        return base.with_overrides(overrides) if overrides else base
    except (DempathError, ValueError) as err:
        raise DiagnosisError(f'{scene.name} seed {seed} {overrides or "baseline"}: {err}') \
            from err


def run_pass(scene: SceneSpec, seed: int, overrides: dict[str, float], *,
             until_s: float = 0.0, frame_s: float = 0.02, keep_depth_m: float = 0.04,
             cache_dir: Path | None = None, backend: str = 'dempath',
             rest_tolerance_m: float = 0.0, shared_settle: bool = False) -> PassRecord:
    """One model pass of ``scene`` with ``overrides`` on the baseline bed of ``seed``.

    Args:
        scene: The baseline scene (the user's model).
        seed: Packing seed.
        overrides: ``{'effect.parameter': value}`` of the candidate (empty: the baseline).
        until_s: The pass is followed until this time [s] (the bed is followed after the tool
            stops); at least until the tool stops.
        frame_s: Interval of the whole-bed frames kept [s].
        keep_depth_m: Particles whose start lies this far below the surface or higher are kept.
        cache_dir: Packing cache (dempath_sim's default if None).
        backend: ``dempath`` (its own engine) or ``liggghts`` (LIGGGHTS 3.8 from the same
            settled bed, ``fill: shared_packing``, re-settled with the run's physics).
        rest_tolerance_m: The follow ends once the bed is at rest to this bound [m]
            (``dempath_sim.runs.rest``; 0: followed to ``until_s``). dempath only.
        shared_settle: Start from the kept re-settled bed of the run's settle key when the
            cache holds one (:func:`ensure_settled`; the same pass to the bit). dempath only.

    Raises:
        DiagnosisError: The simulation failed (message from dempath_sim).
    """
    from dempath_sim.runs import RunOptions, run_scene

    follow_s = max(0.0, until_s - pass_travel_s(scene, overrides))
    changed = pass_scene(scene, seed, overrides, frame_s)
    try:
        options = RunOptions(cache_dir=cache_dir, follow_s=follow_s,
                             rest_tolerance_m=rest_tolerance_m, shared_settle=shared_settle)
        result = (run_scene(changed, options) if backend == 'dempath'
                  else _run_liggghts(changed, options))
    except (DempathError, ValueError) as err:
        msg = f'{scene.name} seed {seed} {overrides or "baseline"}: {err}'
        raise DiagnosisError(msg) from err
    return _record(result, keep_depth_m, overrides, seed)


def settle_key(scene: SceneSpec, seed: int, overrides: dict[str, float]) -> str:
    """The settle key of a library pass (passes with one key share their re-settled bed)."""
    from dempath_sim.runs.shared_settle import settled_key

    return settled_key(pass_scene(scene, seed, overrides))


def ensure_settled(scene: SceneSpec, seed: int, overrides: dict[str, float],
                   cache_dir: Path | None = None) -> bool:
    """Keep the re-settled bed of a library pass in the packing cache (for the passes that
    share its settle key); True if made here.

    Raises:
        DiagnosisError: The simulation failed (message from dempath_sim).
    """
    from dempath_sim.runs.native import keep_settled

    try:
        return keep_settled(pass_scene(scene, seed, overrides), cache_dir)
    except (DempathError, ValueError) as err:
        raise DiagnosisError(f'{scene.name} seed {seed} re-settle: {err}') from err


BACKENDS = ('dempath', 'liggghts')


def _run_liggghts(scene: SceneSpec, options: Any) -> Any:
    """``scene`` on LIGGGHTS from dempath's settled bed of its seed, in a temporary folder."""
    import tempfile

    from dempath_sim.liggghts import LiggghtsBackend

    with tempfile.TemporaryDirectory(prefix='dempath-liggghts-') as work:
        return LiggghtsBackend(work, fill='shared_packing').run(scene, options)


def tool_geometry(scene: SceneSpec) -> tuple[float, float, tuple[float, float, float]]:
    """Tool axis X [m], half the tool's X extent [m] and the candidate cube size [m]."""
    from dempath_sim.engine.mesh import TriangleMesh
    from dempath_sim.runs.physics import TOOL

    try:
        mesh = TriangleMesh.from_stl(scene.tool.mesh, material=TOOL, scale=scene.tool.scale)
    except (DempathError, OSError) as err:
        raise DiagnosisError(f'{scene.tool.mesh}: cannot read the tool ({err})') from err
    lo, hi = mesh.bounds
    cube = tuple(float(v) for v in scene.markers.cube_size_m)
    return float(scene.tool.x_m), float(hi[0] - lo[0]) / 2.0, (cube[0], cube[1], cube[2])


@dataclass(frozen=True)
class CasePass:
    """A pass as a measurement would see it: the scene's marker particles and the tool force.

    Attributes:
        times: (nt,) [s]; markers: (m,) numbers; positions: (nt, m, 3) [m];
        force: (nt, 3) force of the particles on the tool [N].
    """

    times: NDArray[np.float64]
    markers: NDArray[np.int64]
    positions: NDArray[np.float64]
    force: NDArray[np.float64]


def run_case(scene: SceneSpec, seed: int, overrides: dict[str, float], *, follow_s: float = 0.0,
             cache_dir: Path | None = None, own_pour: bool = False,
             backend: str = 'dempath') -> CasePass:
    """A hidden-effect case: ``scene`` with ``overrides`` on a seed the library never used.

    By default the case's bed is poured with the scene file's physics on its own seed and
    re-settled against the tool with the case's physics, the set-up the library's runs use.
    With ``own_pour`` the bed is poured with the case's own physics (``fill.physics: run``), a
    set-up the library never used (one more pour per case; the tiny scene's strongly cohesive
    pours do not settle within its fill time, and such a bed still sinks during the pass).
    ``backend='liggghts'`` runs the pass on LIGGGHTS from the same settled bed (a LIGGGHTS
    user's measurement stand-in).
    """
    from dempath_sim.runs import RunOptions, run_scene

    try:
        base = _sweep_scene(scene.with_overrides(seed=seed))
        changed = base.with_overrides(overrides) if overrides else base
        if own_pour:
            changed = replace(changed, fill=replace(changed.fill, physics='run'))
        options = RunOptions(cache_dir=cache_dir, follow_s=follow_s)
        result = (run_scene(changed, options) if backend == 'dempath'
                  else _run_liggghts(changed, options))
    except (DempathError, ValueError) as err:
        raise DiagnosisError(f'case {overrides or "control"} seed {seed}: {err}') from err
    numbers = result.marker_numbers
    positions = np.stack([result.marker_trajectory(int(n)) for n in numbers], axis=1)
    return CasePass(np.asarray(result.times), np.asarray(numbers, np.int64), positions,
                    np.asarray(result.tool_force))


def ensure_bed(scene: SceneSpec, cache_dir: Path | None = None) -> bool:
    """Make sure the packing cache holds the settled bed a pass of ``scene`` reads; True if made.

    That bed is poured with the physics of ``scene.bed_model()``: the scene file's own effects
    (``fill.physics: scene``, the default), whatever a candidate's overrides change, so runs
    that differ only in the physics share one bed per seed and chaos cancels in paired
    differences; each run then re-settles it against the tool with its own physics
    (``tool.settle_s``), as LIGGGHTS users re-settle a saved bed.
    """
    from dempath_sim.runs.bed import default_cache_dir, fill_bed, packing_key
    from dempath_sim.runs.physics import build_params

    model = scene.bed_model()
    key = packing_key(scene, model)
    if ((cache_dir or default_cache_dir()) / f'{key}.npz').is_file():
        return False
    _, report = fill_bed(scene, model, build_params(scene, model), cache_dir)
    return not report.from_cache


def _record(result: Any, keep_depth_m: float, overrides: dict[str, float],
            seed: int) -> PassRecord:
    """The near-surface part of a run's whole-bed frames, plus the tool's pose and force."""
    snaps = np.asarray(result.snapshot_positions, np.float32)
    start = snaps[0].astype(np.float64)
    surface = float(result.meta['fill']['surface_height_m'])
    keep = np.isfinite(start[:, 1]) & (start[:, 1] >= surface - keep_depth_m)
    at = np.searchsorted(result.times, result.snapshot_times).clip(0, len(result.times) - 1)
    meta = {'seed': seed, 'overrides': overrides, 'surface_height_m': surface,
            'run_id': result.meta.get('run_id', ''),
            'drive_wall_s': result.meta.get('drive_wall_s', 0.0),
            'drive_pair_evaluations': result.meta.get('drive_pair_evaluations', 0),
            'rest_at_s': result.meta.get('rest_at_s'),
            'settle_shared': bool(result.meta.get('settle_shared', False)),
            'tool_stop_s': float(result.meta.get('end_time_s', result.times[-1]))}
    return PassRecord(times=np.asarray(result.snapshot_times, np.float64),
                      ids=np.asarray(result.snapshot_ids)[keep].astype(np.int64),
                      positions=snaps[:, keep], tool_position=result.tool_position[at],
                      force_times=np.asarray(result.times, np.float64),
                      tool_force=np.asarray(result.tool_force, np.float64), meta=meta)


__all__ = [
    'BACKENDS',
    'LIBRARY_CANDIDATES',
    'Candidate',
    'CasePass',
    'ensure_bed',
    'ensure_settled',
    'load_scene',
    'pass_scene',
    'pass_travel_s',
    'physics_key',
    'run_case',
    'run_pass',
    'scene_candidates',
    'settle_key',
    'tool_geometry',
    'travel_time_s',
]


# --- recalibration (dempath_recalibrate): writing the recalibrated scene -----------------------

def write_scene(scene: SceneSpec, overrides: dict[str, float], path: Path,
                comments: list[str]) -> SceneSpec:
    """Write the user's scene file with ``overrides`` (the effects they touch switched on) to
    ``path``, headed by ``comments``; the rest of the file is kept as the user wrote it (a
    relative tool mesh is made absolute). The written file is read back (SceneError if not)."""
    import yaml

    from dempath_sim.scene import load_scene as load_file

    source = Path(str(scene.source))
    raw = yaml.safe_load(source.read_text())
    effects = raw.setdefault('effects', {})
    for dotted, value in overrides.items():
        name, _, param = dotted.partition('.')
        entry = effects.setdefault(name, {})
        entry['enabled'] = True
        entry[param] = float(value)
    mesh = str(raw.get('tool', {}).get('mesh', ''))
    if mesh and ':' not in mesh and not Path(mesh).is_absolute():
        raw['tool']['mesh'] = str((source.parent / mesh).resolve())
    head = ''.join(f'# {line}\n' for line in comments)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix('.tmp')
    tmp.write_text(head + yaml.safe_dump(raw, sort_keys=False, default_flow_style=None))
    tmp.replace(path)
    return load_file(path)
