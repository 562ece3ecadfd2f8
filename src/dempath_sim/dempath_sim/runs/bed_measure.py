"""What a settled bed measures: its surface height, bulk density and solid fraction.

The fill compares these with what the scene asks for (``fill.bulk_density_target_kg_m3``,
``fill.count: surface``) and reports them; the same rules measure a bed made elsewhere (a
LIGGGHTS deck's, a lab's packing file), so that beds are compared by one yardstick.
"""

from __future__ import annotations

import numpy as np

from dempath_sim.effects import PhysicsModel
from dempath_sim.engine.state import SimState
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
