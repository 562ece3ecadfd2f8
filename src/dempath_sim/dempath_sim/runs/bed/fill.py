"""Filling the bin: pour the layers and let them settle, with an on-disk cache of packings.

Each layer (bottom to top) holds the particle volume of the layer at the target solid fraction
(``fill.bulk_density_target_kg_m3`` over the particle density, 0.6 when no target is set), is
inserted at random into a loose slab (``runs.bed.pour``, as LIGGGHTS' ``insert/pack``), dropped
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
(``runs.bed.standing_tool``: the bed poured and settled around the standing tool, and the key then
includes the tool). Particles of one material.
"""

from __future__ import annotations

import hashlib
import logging
from dataclasses import asdict
from pathlib import Path

import numpy as np

from dempath_sim.effects import PhysicsModel
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.errors import SceneError
from dempath_sim.runs.bed.cache import (
    bundled_packing_dir,
    default_cache_dir,
    load_cached,
    packing_key,
    save_cached,
)
from dempath_sim.runs.bed.measure import FillReport, fill_report
from dempath_sim.runs.bed.packing_file import load_packing
from dempath_sim.runs.bed.pour import pour
from dempath_sim.runs.bed.settle import (
    COMPACTION_SETTLE_S,
    Progress,
    compact,
    pour_and_settle,
    settle,
    unreachable,
)
from dempath_sim.runs.bed.standing_tool import fill_engine, fill_tool, without_overlaps
from dempath_sim.runs.physics import PARTICLES
from dempath_sim.scene.spec import SceneSpec

logger = logging.getLogger(__name__)
# 2: random insertion (insert/pack) instead of a jittered lattice; compaction to the target
MAX_SOLID_FRACTION = 0.66  # no random sphere packing is denser (close packing ~0.64)
SURFACE_TRIALS = 4  # pours of fill.count: surface before the surface counts as unreachable


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
    report = fill_report(scene, model, state, key, settled, count_scale=count_scale)
    if target is None or report.within_tolerance:
        return state, report
    if report.bulk_density_kg_m3 > target:
        raise unreachable(scene, asdict(report), 'the loosest pour (full friction)')
    state, scale = compact(scene, model, params, state, progress, tool)
    state, settled = settle(fill_engine(scene, params, tool), state, scene,
                            state.time + COMPACTION_SETTLE_S, progress)
    return state, fill_report(scene, model, state, key, settled, scale, count_scale=count_scale)


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
    report = fill_report(scene, model, state, f'file:{digest}', True, source=str(path))
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
            cached = load_cached(found_path, params) if found_path.is_file() else None
            if cached is not None:
                return cached
    state, report = pour_to_target(scene, model, params, key, progress)
    state.time, state.step = 0.0, 0
    if scene.fill.cache:
        save_cached(path, state, report)
    return state, report
