"""What a settled bed measures: its surface height, bulk density and solid fraction.

The fill compares these with what the scene asks for (``fill.bulk_density_target_kg_m3``,
``fill.count: surface``) and reports them; the same rules measure a bed made elsewhere (a
LIGGGHTS deck's, a lab's packing file), so that beds are compared by one yardstick.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dempath_sim.effects import PhysicsModel
from dempath_sim.engine.state import SimState
from dempath_sim.runs.bed.pour import target_solid_fraction
from dempath_sim.scene.spec import SceneSpec


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


def fill_report(scene: SceneSpec, model: PhysicsModel, state: SimState, key: str, settled: bool,
            scale: float = 1.0, source: str = 'pour', count_scale: float = 1.0) -> FillReport:
    """The report of a bed: what ``measure`` finds, against the scene's target."""
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
