"""Energy bookkeeping of a DEM state (numpy, for checks and reports, not for stepping).

Total mechanical energy = translational + rotational kinetic energy + gravitational potential
energy (-m g . x) + Hertzian elastic energy of every overlap,
U = 8/15 E* sqrt(R*) delta^(5/2) (the integral of F_n = 4/3 E* sqrt(R*) delta^(3/2)), for
particle pairs and particle-plane contacts (R* = r). Tangential springs are not counted.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

from dempath_sim.engine.materials import pair_properties
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.walls import Plane


def elastic_energy(state: SimState, params: SimParams, walls: Sequence[Plane] = ()) -> float:
    """Hertzian elastic energy of all particle-particle and particle-plane overlaps [J]."""
    mats = params.materials
    energy = 0.0
    if state.n > 1:
        tree = cKDTree(state.positions)
        pairs = tree.query_pairs(2.0 * float(state.radii.max()), output_type='ndarray')
        for i, j in pairs:
            d = float(np.linalg.norm(state.positions[i] - state.positions[j]))
            delta = state.radii[i] + state.radii[j] - d
            if delta > 0:
                e_star = pair_properties(mats[state.material[i]],
                                         mats[state.material[j]]).effective_youngs
                r_eff = state.radii[i] * state.radii[j] / (state.radii[i] + state.radii[j])
                energy += 8.0 / 15.0 * e_star * np.sqrt(r_eff) * delta ** 2.5
    for wall in walls:
        dist = (state.positions - np.asarray(wall.point)) @ np.asarray(wall.normal)
        delta = state.radii - dist
        for i in np.flatnonzero(delta > 0):
            e_star = pair_properties(mats[state.material[i]], mats[wall.material]).effective_youngs
            energy += 8.0 / 15.0 * e_star * np.sqrt(state.radii[i]) * delta[i] ** 2.5
    return float(energy)


def total_energy(state: SimState, params: SimParams, walls: Sequence[Plane] = ()) -> float:
    """Kinetic + gravitational + Hertzian elastic energy [J]."""
    potential = -float(np.sum(state.masses * (state.positions @ np.asarray(params.gravity))))
    return state.kinetic_energy() + potential + elastic_energy(state, params, walls)
