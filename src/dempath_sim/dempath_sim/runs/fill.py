"""Filling the bin: pour the layers and let them settle, with an on-disk cache of packings.

Each layer (bottom to top) is generated as a loose jittered cubic lattice holding the particle
volume of the layer at the target solid fraction (``fill.bulk_density_target_kg_m3`` over the
particle density, 0.6 when no target is set), dropped under gravity inside the bin walls and
settled until the fastest particle is slower than ``fill.settle_speed_m_s``. The report gives
the achieved bulk density (mass below the surface over the bin area times the bed height),
solid fraction and surface height (mean over the bin, away from the walls, of the highest
particle top per column of cells two top-layer diameters wide).

Settled packings are cached as ``<cache>/<key>.npz``; the key hashes everything that determines
the packing (bin, layers, particle and wall physics, fill settings, numerics, seed, engine
version), so repeated runs of a scene, and runs that only change the tool or its speed, skip
the fill. Assumptions: no tool during the fill; particles of one material.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_sim.effects import PhysicsModel
from dempath_sim.engine import Engine
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.runs.physics import PARTICLES, bin_walls, scaled_friction
from dempath_sim.scene.spec import LayerSpec, NumericsSpec, SceneSpec

logger = logging.getLogger(__name__)

FILL_VERSION = 1  # bump when the pour/settle procedure changes (invalidates cached packings)
DEFAULT_SOLID_FRACTION = 0.6  # random loose-to-close packing of spheres
LATTICE_GAP = 1.04  # lattice spacing / largest diameter of a layer
SETTLE_CHECK_S = 0.02  # sim time between settling checks [s]
MIN_SETTLE_S = 0.1  # never stop before this much sim time [s]
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
        key: Cache key of the packing.
        from_cache: Whether the packing was read from the cache.
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


def default_cache_dir() -> Path:
    """``$DEMPATH_CACHE_DIR/packings`` or ``~/.cache/dempath/packings``."""
    root = os.environ.get('DEMPATH_CACHE_DIR')
    base = Path(root) if root else Path.home() / '.cache' / 'dempath'
    return base / 'packings'


def bundled_packing_dir() -> Path:
    """Settled packings shipped with dempath for its bundled scenes (read-only, looked up last)."""
    return Path(__file__).resolve().parents[1] / 'data' / 'packings'


def packing_key(scene: SceneSpec, model: PhysicsModel) -> str:
    """Hash (hex, 20 chars) of everything that determines the settled packing.

    The overlap limit is a safety stop, not a parameter of the packing, so it is left out (set
    to its default) along with everything about the tool.
    """
    numerics = asdict(replace(scene.sim,
                              max_overlap_fraction=NumericsSpec.max_overlap_fraction))
    for option in ('coulomb_limit', 'contact_forms'):  # options added after packings were
        if numerics[option] == getattr(NumericsSpec, option):  # shipped: at their defaults
            del numerics[option]  # the keys of those packings stay valid
    physics = asdict(replace(model, speed_scale=1.0, particle_tool=model.particle_particle,
                             tool_density_kg_m3=0.0, tool_youngs_modulus_pa=0.0,
                             tool_poisson=0.0))
    payload = {'version': FILL_VERSION, 'engine': ENGINE_VERSION,
               'bin': asdict(scene.bin), 'layers': [asdict(x) for x in scene.layers],
               'physics': physics, 'fill': asdict(replace(scene.fill, cache=True)),
               'sim': numerics,
               'seed': scene.seed}
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def target_solid_fraction(scene: SceneSpec, model: PhysicsModel) -> float:
    """Solid fraction the pour aims at: target bulk density / particle density, or 0.6."""
    target = scene.fill.bulk_density_target_kg_m3
    if target is None:
        return DEFAULT_SOLID_FRACTION
    phi = target / model.particle_density_kg_m3
    if not 0.05 < phi < 0.74:
        logger.warning('fill: target bulk density %.0f kg/m^3 needs a solid fraction %.2f that '
                       'random sphere packings do not reach', target, phi)
    return float(min(max(phi, 0.05), 0.64))


def sample_diameters(layer: LayerSpec, factor: float, volume_m3: float,
                     rng: np.random.Generator) -> NDArray[np.float64]:
    """Diameters [m] of one layer whose sphere volumes add up to ``volume_m3``."""
    d0 = layer.diameter_m * factor
    dist = layer.distribution
    n_guess = max(1, math.ceil(volume_m3 / (math.pi / 6 * d0**3) * 1.3))
    if dist.kind == 'uniform':
        d = d0 * (1.0 + dist.spread * rng.uniform(-1.0, 1.0, n_guess))
    elif dist.kind == 'discrete':
        sizes = np.asarray(dist.diameters_m) * factor
        number_w = np.asarray(dist.mass_fractions) / sizes**3  # mass fraction -> number fraction
        d = rng.choice(sizes, size=n_guess * 4, p=number_w / number_w.sum())
    else:
        d = np.full(n_guess, d0)
    cum = np.cumsum(math.pi / 6 * d**3)
    return d[: int(np.searchsorted(cum, volume_m3)) + 1]


def lattice(scene: SceneSpec, diameters: NDArray[np.float64], y_start: float,
            rng: np.random.Generator, gap: float = LATTICE_GAP,
            ) -> tuple[NDArray[np.float64], float]:
    """Jittered cubic-lattice centres (n, 3) [m] for ``diameters`` above ``y_start``; top y.

    ``gap`` is the lattice spacing over the largest diameter (< 1 puts neighbours in contact).
    """
    a = float(diameters.max()) * gap
    half_w = scene.bin.width_x_m / 2
    nx = max(1, int((scene.bin.width_x_m - a) // a) + 1)
    nz = max(1, int((scene.bin.length_z_m - a) // a) + 1)
    k = np.arange(len(diameters))
    ix, iz, iy = k % nx, (k // nx) % nz, k // (nx * nz)
    jitter = rng.uniform(-1.0, 1.0, (len(k), 3)) * 0.5 * (a - diameters[:, None]) / 2
    pos = np.column_stack([-half_w + a / 2 + ix * a, y_start + a / 2 + iy * a, a / 2 + iz * a])
    return pos + jitter, y_start + (int(iy.max()) + 1) * a


def pour(scene: SceneSpec, model: PhysicsModel, params: SimParams,
         gap: float = LATTICE_GAP) -> SimState:
    """The loose initial state of all layers, seeded by ``scene.seed``; ``extra['layer']``.

    ``gap``: lattice spacing over the largest diameter of a layer (see ``lattice``).
    """
    rng = np.random.default_rng(scene.seed)
    phi = target_solid_fraction(scene, model)
    area = scene.bin.width_x_m * scene.bin.length_z_m
    y, parts, radii, layer_of = -scene.bed_thickness_m, [], [], []
    for index, layer in enumerate(scene.layers):
        factor = model.coarse_grain if layer.coarse_grained else 1.0
        d = sample_diameters(layer, factor, phi * area * layer.thickness_m, rng)
        pos, y = lattice(scene, d, y, rng, gap)
        parts.append(pos)
        radii.append(d / 2)
        layer_of.append(np.full(len(d), index, np.int32))
    positions = np.concatenate(parts)
    velocities = rng.normal(0.0, 0.01, positions.shape)  # breaks the lattice symmetry [m/s]
    state = SimState.from_spheres(positions, np.concatenate(radii), PARTICLES, params,
                                  velocities=velocities)
    state.extra['layer'] = np.concatenate(layer_of)
    return state


def surface_height(scene: SceneSpec, state: SimState) -> float:
    """Y of the settled surface [m]: mean over inner cell columns of the highest particle top.

    Cells are two top-layer diameters wide; the columns along the walls are left out.
    """
    top = len(scene.layers) - 1
    in_top = state.extra['layer'] == top if 'layer' in state.extra else slice(None)
    cell = 4.0 * float(state.radii[in_top].max())
    half_w, length = scene.bin.width_x_m / 2, scene.bin.length_z_m
    nx, nz = max(1, int(2 * half_w // cell)), max(1, int(length // cell))
    ix = np.clip(((state.positions[:, 0] + half_w) / (2 * half_w) * nx).astype(int), 0, nx - 1)
    iz = np.clip((state.positions[:, 2] / length * nz).astype(int), 0, nz - 1)
    tops = np.full((nx, nz), -np.inf)
    np.maximum.at(tops, (ix, iz), state.positions[:, 1] + state.radii)
    inner = tops[1:-1, 1:-1] if nx > 2 and nz > 2 else tops
    return float(np.mean(inner[np.isfinite(inner)]))


def measure(scene: SceneSpec, model: PhysicsModel, state: SimState) -> dict[str, float]:
    """Surface height [m], bulk density [kg/m^3] and solid fraction [1] of a settled bed.

    The solid fraction is the volume of the spheres whose centres lie in a measuring box over
    the volume of the box; the box keeps two largest diameters away from the side walls and the
    floor and one below the surface, so that wall layering and the rough top do not bias it.
    """
    surface = surface_height(scene, state)
    d = 2.0 * float(state.radii.max())
    half_w, length = scene.bin.width_x_m / 2, scene.bin.length_z_m
    lo = np.array([-half_w + 2 * d, -scene.bed_thickness_m + 2 * d, 2 * d])
    hi = np.array([half_w - 2 * d, surface - d, length - 2 * d])
    if np.any(hi <= lo):  # bin too small for a margin: use the whole bed
        lo = np.array([-half_w, -scene.bed_thickness_m, 0.0])
        hi = np.array([half_w, surface, length])
    inside = np.all((state.positions >= lo) & (state.positions <= hi), axis=1)
    volume = float(np.sum(4.0 / 3.0 * np.pi * state.radii[inside] ** 3))
    phi = volume / float(np.prod(hi - lo))
    return {'surface_height_m': surface, 'solid_fraction': phi,
            'bulk_density_kg_m3': phi * model.particle_density_kg_m3}


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
                    progress: Progress | None = None) -> tuple[SimState, bool]:
    """Settle the poured state, first with scaled friction when ``fill.friction_scale`` < 1."""
    walls = bin_walls(scene)
    limit = scene.fill.max_settle_time_s
    factor = scene.fill.friction_scale
    if factor < 1.0:
        state, _ = settle(Engine(scaled_friction(params, factor), walls), state, scene,
                          limit / 2, progress)
    return settle(Engine(params, walls), state, scene, limit, progress)


def fill_bed(scene: SceneSpec, model: PhysicsModel, params: SimParams,
             cache_dir: Path | None = None, progress: Progress | None = None,
             ) -> tuple[SimState, FillReport]:
    """Pour and settle the bed of ``scene`` (or read it from the cache).

    Args:
        scene: The scene.
        model: Its physics model (``scene.physics_model()``, maybe with overrides).
        params: Engine parameters with materials PARTICLES, WALLS (and TOOL).
        cache_dir: Packing cache directory; ``default_cache_dir()`` if None.
        progress: Called with (sim time, max settle time) during the settle.

    Returns:
        The settled state (time reset to 0, velocities as settled) and the report.
    """
    key = packing_key(scene, model)
    path = (cache_dir or default_cache_dir()) / f'{key}.npz'
    if scene.fill.cache:
        for found_path in (path, bundled_packing_dir() / f'{key}.npz'):
            if found_path.is_file():
                return _load_cached(found_path, params)
    state, settled = pour_and_settle(scene, pour(scene, model, params), params, progress)
    found: dict[str, Any] = measure(scene, model, state)
    target = scene.fill.bulk_density_target_kg_m3
    within = target is None or abs(found['bulk_density_kg_m3'] - target) <= (
        scene.fill.tolerance * target)
    if not within:
        logger.warning('fill: bulk density %.0f kg/m^3 misses the target %.0f kg/m^3 by more '
                       'than %.0f %%', found['bulk_density_kg_m3'], target,
                       100 * scene.fill.tolerance)
    report = FillReport(n_particles=state.n, target_bulk_density_kg_m3=target,
                        within_tolerance=within, settle_time_s=state.time, settled=settled,
                        key=key, floor_y_m=-scene.bed_thickness_m, **found)
    state.time, state.step = 0.0, 0
    if scene.fill.cache:
        _save_cached(path, state, report)
    return state, report


def _save_cached(path: Path, state: SimState, report: FillReport) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix('.tmp.npz')
    np.savez_compressed(tmp, positions=state.positions, velocities=state.velocities,
                        angular_velocities=state.angular_velocities, radii=state.radii,
                        ids=state.ids, layer=state.extra.get('layer', np.zeros(state.n)),
                        report=np.array(json.dumps(asdict(report))))
    tmp.replace(path)


def _load_cached(path: Path, params: SimParams) -> tuple[SimState, FillReport]:
    with np.load(path, allow_pickle=False) as data:
        state = SimState.from_spheres(data['positions'], data['radii'], PARTICLES, params,
                                      velocities=data['velocities'], ids=data['ids'])
        state.angular_velocities[:] = data['angular_velocities']
        state.extra['layer'] = data['layer'].astype(np.int32)
        fields: dict[str, Any] = json.loads(str(data['report']))
    fields['from_cache'] = True
    logger.info('fill: packing %s read from the cache', path.name)
    return state, FillReport(**fields)
