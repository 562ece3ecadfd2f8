"""Filling the bin: pour the layers and let them settle, with an on-disk cache of packings.

Each layer (bottom to top) holds the particle volume of the layer at the target solid fraction
(``fill.bulk_density_target_kg_m3`` over the particle density, 0.6 when no target is set), is
inserted at random into a loose slab (``runs.pour``, as LIGGGHTS' ``insert/pack``), dropped
under gravity inside the bin walls and settled until the fastest particle is slower than
``fill.settle_speed_m_s``. When the settled bed is looser than the target by more than
``fill.tolerance`` (2 % by default), it is compacted by settling it again with friction and
rolling resistance scaled down (a bisection on the scale, each trial from the last bed that was
still too loose) until the bulk density is within the tolerance, then settled with the full
physics; a target the pour cannot reach (denser than the frictionless bed, or looser than the
full-friction pour) stops with one SceneError naming the value and what was reached. The
number of grains is the target solid fraction times the layers' nominal volume
(``fill.count: volume``), or, with ``fill.count: surface``, scaled by re-pouring until the
settled surface lies at the nominal surface Y = 0 (within ``fill.tolerance`` x thickness). The
bed is poured with the scene file's physics (``fill.physics: scene``) so that runs which only
change effects share it; ``fill.packing`` reads a bed made elsewhere instead. The report gives
the achieved bulk density (mass below the surface over the bin area times the bed height),
solid fraction and surface height (mean over the bin, away from the walls, of the highest
particle top per column of cells two top-layer diameters wide).

Settled packings are cached as ``<cache>/<key>.npz``; the key hashes everything that determines
the packing (bin, layers, particle and wall physics, fill settings, numerics, seed, engine
version), so repeated runs of a scene, and runs that only change the tool or its speed, skip
the fill. The tool is not in the bin during the fill unless ``tool.placement: poured``
(``runs.fill_tool``: the bed poured and settled around the standing tool, and the key then
includes the tool). Particles of one material.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import zipfile
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from dempath_sim.effects import PhysicsModel
from dempath_sim.engine import Engine
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.errors import SceneError
from dempath_sim.runs.bed_measure import measure
from dempath_sim.runs.fill_tool import FillTool, fill_engine, fill_tool, tool_key, without_overlaps
from dempath_sim.runs.packing_io import load_packing
from dempath_sim.runs.physics import PARTICLES, scaled_friction
from dempath_sim.runs.pour import pour, target_solid_fraction
from dempath_sim.scene.spec import FillSpec, NumericsSpec, SceneSpec

logger = logging.getLogger(__name__)

FILL_VERSION = 2  # bump when the pour/settle procedure changes (invalidates cached packings)
# 2: random insertion (insert/pack) instead of a jittered lattice; compaction to the target
MAX_SOLID_FRACTION = 0.66  # no random sphere packing is denser (close packing ~0.64)
COMPACTION_TRIALS = 7  # friction-scale bisection steps before a target counts as unreachable
COMPACTION_SETTLE_S = 0.4  # longest settle of one compaction trial [s]
SETTLE_CHECK_S = 0.02  # sim time between settling checks [s]
MIN_SETTLE_S = 0.1  # never stop before this much sim time [s]
SURFACE_TRIALS = 4  # pours of fill.count: surface before the surface counts as unreachable
# Bump when an engine change alters the physics of settling (invalidates packings). Changes that
# only reorder floating-point sums (cell-order sorting of particles, per-patch mesh history: the
# fill has no tool) leave a cached bed an equally valid sample of the same physics, so they keep
# the version and the shipped packing.
ENGINE_VERSION = 1


@dataclass(frozen=True)
class FillReport:
    """What the fill achieved.

    Attributes:
        n_particles: Particles in the bed.
        bulk_density_kg_m3: Achieved bulk density [kg/m^3].
        solid_fraction: Achieved solid fraction [1].
        surface_height_m: Y of the settled surface [m] (nominal 0).
        floor_y_m: Y of the bin floor [m].
        target_bulk_density_kg_m3: Target from the scene, or None.
        within_tolerance: Whether the target was met within ``fill.tolerance`` (True if none).
        settle_time_s: Simulated pour and settle time [s].
        settled: Whether the settling criterion was met before ``max_settle_time_s``.
        key: Cache key of the packing (``file:<sha>`` for a packing file).
        from_cache: Whether the packing was read from the cache.
        target_solid_fraction: Target bulk density / particle density, or None.
        compaction_friction_scale: Friction scale of the compaction settle (1: none).
        source: ``pour`` or the packing file's path.
        count_scale: Grains poured / the volume count (``fill.count: surface``; 1 otherwise).
    """

    n_particles: int
    bulk_density_kg_m3: float
    solid_fraction: float
    surface_height_m: float
    floor_y_m: float
    target_bulk_density_kg_m3: float | None
    within_tolerance: bool
    settle_time_s: float
    settled: bool
    key: str
    from_cache: bool = False
    target_solid_fraction: float | None = None
    compaction_friction_scale: float = 1.0
    source: str = 'pour'
    count_scale: float = 1.0


def default_cache_dir() -> Path:
    """``$DEMPATH_CACHE_DIR/packings`` or ``~/.cache/dempath/packings``."""
    root = os.environ.get('DEMPATH_CACHE_DIR')
    base = Path(root) if root else Path.home() / '.cache' / 'dempath'
    return base / 'packings'


# The overlap-limit value every packing key is made with: the default when the shipped packings
# were made; a later default does not change the keys.
KEY_OVERLAP_FRACTION = 0.3


def bundled_packing_dir() -> Path:
    """Settled packings shipped with dempath for its bundled scenes (read-only, looked up last)."""
    return Path(__file__).resolve().parents[1] / 'data' / 'packings'


def packing_key(scene: SceneSpec, model: PhysicsModel) -> str:
    """Hash (hex, 20 chars) of everything that determines the settled packing.

    The overlap limit is a safety stop, not a parameter of the packing, so it is left out (set
    to KEY_OVERLAP_FRACTION, whatever the scene says) along with everything about the tool.
    """
    numerics = asdict(replace(scene.sim, max_overlap_fraction=KEY_OVERLAP_FRACTION))
    for option in ('coulomb_limit', 'contact_forms'):  # options added after packings were
        if numerics[option] == getattr(NumericsSpec, option):  # shipped: at their defaults
            del numerics[option]  # the keys of those packings stay valid
    fill = asdict(replace(scene.fill, cache=True))
    if fill['count'] == FillSpec.count:  # added after packings were shipped, likewise
        del fill['count']
    if numerics.get('contact_forms') == 'liggghts':  # its pair springs now outlive a
        numerics['pair_springs'] = 'until_list_build'  # separation: packings settled before
    physics = asdict(replace(model, speed_scale=1.0, particle_tool=model.particle_particle,
                             tool_density_kg_m3=0.0, tool_youngs_modulus_pa=0.0,
                             tool_poisson=0.0))
    payload = {'version': FILL_VERSION, 'engine': ENGINE_VERSION,
               'bin': asdict(scene.bin), 'layers': [asdict(x) for x in scene.layers],
               'physics': physics, 'fill': fill,
               'sim': numerics,
               'seed': scene.seed}
    standing = tool_key(scene)
    if standing is not None:  # a bed poured around the tool belongs to the tool
        payload['tool'] = standing
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


Progress = Callable[[float, float], None]  # (sim time [s], max settle time [s])


def settle(engine: Engine, state: SimState, scene: SceneSpec, until_s: float,
           progress: Progress | None = None) -> tuple[SimState, bool]:
    """Step until the fastest particle is slower than the settling speed (or ``until_s``)."""
    engine.bind(state)
    dt = float(engine.dt or 0.0)
    chunk = max(1, round(SETTLE_CHECK_S / dt))
    start, vmax = state.time, math.inf
    while state.time < until_s:
        state = engine.run(state, chunk)
        if progress is not None:
            progress(state.time, scene.fill.max_settle_time_s)
        vmax = float(np.sqrt((state.velocities**2).sum(axis=1)).max(initial=0.0))
        if state.time - start >= MIN_SETTLE_S and vmax < scene.fill.settle_speed_m_s:
            return state, True
    logger.warning('fill: bed still moving (%.3g m/s) after %.2f s; using it anyway', vmax,
                   state.time)
    return state, False


def pour_and_settle(scene: SceneSpec, state: SimState, params: SimParams,
                    progress: Progress | None = None,
                    tool: FillTool | None = None) -> tuple[SimState, bool]:
    """Settle the poured state, first with scaled friction when ``fill.friction_scale`` < 1
    (around ``tool`` standing at its start, when given)."""
    limit = scene.fill.max_settle_time_s
    factor = scene.fill.friction_scale
    if factor < 1.0:
        state, _ = settle(fill_engine(scene, scaled_friction(params, factor), tool), state,
                          scene, limit / 2, progress)
    return settle(fill_engine(scene, params, tool), state, scene, limit, progress)


def _copy(state: SimState) -> SimState:
    return state.subset(np.ones(state.n, bool))


def _unreachable(scene: SceneSpec, found: dict[str, float], what: str) -> SceneError:
    target = scene.fill.bulk_density_target_kg_m3
    return SceneError(
        f'{scene.source}: fill.bulk_density_target_kg_m3: {target:g} kg/m^3 cannot be reached '
        f'within {100 * scene.fill.tolerance:g} %: {what} gives '
        f"{found['bulk_density_kg_m3']:.0f} kg/m^3 (solid fraction "
        f"{found['solid_fraction']:.3f})")


def compact(scene: SceneSpec, model: PhysicsModel, params: SimParams, state: SimState,
            progress: Progress | None = None,
            tool: FillTool | None = None) -> tuple[SimState, float]:
    """Settle the bed with friction scaled down until its bulk density reaches the target.

    Bisection on the friction scale in (0, 1): a trial settles the last bed that was still
    too loose with that scale; too loose, it becomes the new start and the scale goes down;
    too dense, the scale goes up. Returns the bed within the tolerance and the scale used.

    Raises:
        SceneError: The target is denser than the bed reaches with friction scaled to ~0.
    """
    phi_t = target_solid_fraction(scene, model)
    tol = scene.fill.tolerance * phi_t
    hi, lo, found = 1.0, 0.0, measure(scene, model, state)
    for _ in range(COMPACTION_TRIALS):
        scale = 0.5 * (hi + lo)
        trial, _ = settle(fill_engine(scene, scaled_friction(params, scale), tool),
                          _copy(state), scene, state.time + COMPACTION_SETTLE_S, progress)
        found = measure(scene, model, trial)
        logger.info('fill: compaction with friction x %.3g: solid fraction %.4f (target %.4f)',
                    scale, found['solid_fraction'], phi_t)
        if abs(found['solid_fraction'] - phi_t) <= tol:
            return trial, scale
        if found['solid_fraction'] < phi_t:
            hi, state = scale, trial
        else:
            lo = scale
    raise _unreachable(scene, found, f'compaction down to friction x {0.5 * (hi + lo):.3g}')


def _report(scene: SceneSpec, model: PhysicsModel, state: SimState, key: str, settled: bool,
            scale: float = 1.0, source: str = 'pour', count_scale: float = 1.0) -> FillReport:
    found: dict[str, Any] = measure(scene, model, state)
    target = scene.fill.bulk_density_target_kg_m3
    within = target is None or abs(found['bulk_density_kg_m3'] - target) <= (
        scene.fill.tolerance * target)
    return FillReport(n_particles=state.n, target_bulk_density_kg_m3=target,
                      within_tolerance=within, settle_time_s=state.time, settled=settled,
                      key=key, floor_y_m=-scene.bed_thickness_m,
                      target_solid_fraction=None if target is None else target_solid_fraction(
                          scene, model),
                      compaction_friction_scale=scale, source=source,
                      count_scale=count_scale, **found)


def pour_to_target(scene: SceneSpec, model: PhysicsModel, params: SimParams, key: str,
                   progress: Progress | None = None) -> tuple[SimState, FillReport]:
    """Pour, settle and (with a target) compact the bed; SceneError if it cannot be reached.

    With ``fill.count: surface`` the whole pour is repeated with the number of grains scaled by
    thickness / (thickness + surface height) (the bed's height is proportional to its grains)
    until the settled surface lies within ``fill.tolerance`` x thickness of Y = 0.
    """
    target = scene.fill.bulk_density_target_kg_m3
    rho = model.particle_density_kg_m3
    if target is not None and target / rho > MAX_SOLID_FRACTION:
        raise SceneError(
            f'{scene.source}: fill.bulk_density_target_kg_m3: {target:g} kg/m^3 needs a solid '
            f'fraction {target / rho:.3f}; random sphere packings reach at most about '
            f'{MAX_SOLID_FRACTION} ({MAX_SOLID_FRACTION * rho:.0f} kg/m^3 with these particles)')
    scale, thickness = 1.0, scene.bed_thickness_m
    for _ in range(SURFACE_TRIALS):
        state, report = _pour_once(scene, model, params, key, progress, scale)
        height = report.surface_height_m
        if scene.fill.count != 'surface' or abs(height) <= scene.fill.tolerance * thickness:
            return state, report
        logger.info('fill: surface %.1f mm from Y = 0 with %d grains; pouring again',
                    1e3 * height, state.n)
        scale *= thickness / (thickness + height)
    raise SceneError(
        f'{scene.source}: fill.count: surface: the settled surface stays {1e3 * height:.1f} mm '
        f'from Y = 0 after {SURFACE_TRIALS} pours (tolerance '
        f'{1e3 * scene.fill.tolerance * thickness:.1f} mm); raise fill.tolerance')


def _pour_once(scene: SceneSpec, model: PhysicsModel, params: SimParams, key: str,
               progress: Progress | None, count_scale: float) -> tuple[SimState, FillReport]:
    """One pour of ``count_scale`` x the volume count, settled and compacted to the target."""
    target = scene.fill.bulk_density_target_kg_m3
    tool = fill_tool(scene)
    state = without_overlaps(pour(scene, model, params, count_scale), tool)
    state, settled = pour_and_settle(scene, state, params, progress, tool)
    report = _report(scene, model, state, key, settled, count_scale=count_scale)
    if target is None or report.within_tolerance:
        return state, report
    if report.bulk_density_kg_m3 > target:
        raise _unreachable(scene, asdict(report), 'the loosest pour (full friction)')
    state, scale = compact(scene, model, params, state, progress, tool)
    state, settled = settle(fill_engine(scene, params, tool), state, scene,
                            state.time + COMPACTION_SETTLE_S, progress)
    return state, _report(scene, model, state, key, settled, scale, count_scale=count_scale)


def packing_from_file(scene: SceneSpec, model: PhysicsModel, params: SimParams,
                      path: Path) -> tuple[SimState, FillReport]:
    """The scene's ``fill.packing`` as the bed (checked; at rest; layers by nearest size)."""
    pos, radii = load_packing(scene, path)
    state = SimState.from_spheres(pos, radii, PARTICLES, params)
    sizes = np.array([layer.diameter_m * (model.coarse_grain if layer.coarse_grained else 1.0)
                      for layer in scene.layers])
    state.extra['layer'] = np.argmin(np.abs(2 * radii[:, None] - sizes[None]), axis=1).astype(
        np.int32)
    digest = hashlib.sha256(path.read_bytes()).hexdigest()[:12]
    report = _report(scene, model, state, f'file:{digest}', True, source=str(path))
    if not report.within_tolerance:
        logger.warning('fill: packing %s has bulk density %.0f kg/m^3, not the target %.0f',
                       path, report.bulk_density_kg_m3, report.target_bulk_density_kg_m3)
    return state, report


def fill_bed(scene: SceneSpec, model: PhysicsModel, params: SimParams,
             cache_dir: Path | None = None, progress: Progress | None = None,
             ) -> tuple[SimState, FillReport]:
    """Pour and settle the bed of ``scene`` (or read it from the cache or ``fill.packing``).

    Args:
        scene: The scene.
        model: The physics the bed is poured with (``scene.bed_model()``: the scene file's
            effects unless ``fill.physics: run``).
        params: Engine parameters of ``model`` with materials PARTICLES, WALLS (and TOOL).
        cache_dir: Packing cache directory; ``default_cache_dir()`` if None.
        progress: Called with (sim time, max settle time) during the settle.

    Returns:
        The settled state (time reset to 0, velocities as settled) and the report.

    Raises:
        SceneError: A bad packing file or a bulk density target the pour cannot reach.
    """
    if scene.fill.packing is not None:
        return packing_from_file(scene, model, params, scene.fill.packing)
    key = packing_key(scene, model)
    path = (cache_dir or default_cache_dir()) / f'{key}.npz'
    if scene.fill.cache:
        for found_path in (path, bundled_packing_dir() / f'{key}.npz'):
            cached = _load_cached(found_path, params) if found_path.is_file() else None
            if cached is not None:
                return cached
    state, report = pour_to_target(scene, model, params, key, progress)
    state.time, state.step = 0.0, 0
    if scene.fill.cache:
        _save_cached(path, state, report)
    return state, report


def _save_cached(path: Path, state: SimState, report: FillReport) -> None:
    """Write the packing beside its final name and rename it into place (atomic: a killed run
    leaves no half-written entry; concurrent writers each use their own temporary file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f'.{path.stem}.{os.getpid()}.tmp.npz')
    np.savez_compressed(tmp, positions=state.positions, velocities=state.velocities,
                        angular_velocities=state.angular_velocities, radii=state.radii,
                        ids=state.ids, layer=state.extra.get('layer', np.zeros(state.n)),
                        report=np.array(json.dumps(asdict(report))))
    tmp.replace(path)


# What a damaged cache entry raises on reading: truncated or empty zip (BadZipFile, EOFError),
# a missing array (KeyError), wrong shapes or JSON (ValueError, TypeError), unreadable (OSError).
_DAMAGED = (zipfile.BadZipFile, EOFError, KeyError, ValueError, TypeError, OSError)


def _load_cached(path: Path, params: SimParams) -> tuple[SimState, FillReport] | None:
    """The cached packing, or None when the entry is damaged: it is then named in a warning,
    set aside as ``<name>.corrupt`` (when the cache is writable) and the bed is poured again."""
    try:
        with np.load(path, allow_pickle=False) as data:
            state = SimState.from_spheres(data['positions'], data['radii'], PARTICLES, params,
                                          velocities=data['velocities'], ids=data['ids'])
            state.angular_velocities[:] = data['angular_velocities']
            state.extra['layer'] = data['layer'].astype(np.int32)
            fields: dict[str, Any] = json.loads(str(data['report']))
        fields['from_cache'] = True
        report = FillReport(**fields)
    except _DAMAGED as err:
        aside = path.with_name(path.name + '.corrupt')
        try:
            path.replace(aside)
            where = f'set aside as {aside.name}'
        except OSError:
            where = 'left in place (read-only)'
        logger.warning('fill: cached packing %s is damaged (%s: %s); %s, pouring the bed again',
                       path, type(err).__name__, err, where)
        return None
    logger.info('fill: packing %s read from the cache', path.name)
    return state, report
