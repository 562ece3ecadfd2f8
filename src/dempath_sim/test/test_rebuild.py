"""The neighbour list kept while grains move together (engine/rebuild.py) on the real engine: a
plate driven through a bed at 1 m/s never meets a contact missing from the list, and the list is
built fewer times than by the whole-bed rule."""

from __future__ import annotations

import numpy as np

from dempath_sim.engine import Engine, SimState, ToolPose, TriangleMesh
from dempath_sim.engine.neighbors import build_neighbor_list
from dempath_sim.engine.walls import box_walls

from .sand_beds import RADIUS, lattice_bed, lattice_centres, sand_params

PARAMS = sand_params()
LO, HI = (-0.016, 0.0, -0.016), (0.016, 0.1, 0.064)  # m
START = np.array([0.0, 0.004, LO[2] + 0.003])  # the plate's lower edge, its start [m]
SPEED = 1.0  # m/s along +Z


def _bed() -> SimState:
    """About 1,000 grains on a jittered lattice, barely touching, at rest (they sag a little)."""
    pos = lattice_centres(LO, HI, 6, 2.02, 0.005, 4)
    in_slot = (np.abs(pos[:, 2] - START[2]) < 2 * RADIUS) & (pos[:, 1] > START[1] - RADIUS)
    return lattice_bed(PARAMS, pos[~in_slot])


def _plate() -> TriangleMesh:
    """A vertical plate 20 mm wide and 50 mm high, normal Z, its lower edge at y = 0."""
    w = 0.01
    tris = np.array([[[-w, 0.0, 0.0], [w, 0.0, 0.0], [w, 0.05, 0.0]],
                     [[-w, 0.0, 0.0], [w, 0.05, 0.0], [-w, 0.05, 0.0]]])
    return TriangleMesh(tris, material=1)


def _motion(t: float) -> ToolPose:
    return ToolPose(START + np.array([0.0, 0.0, SPEED * t]), np.array([0.0, 0.0, SPEED]))


def _missing_contacts(state: SimState, engine: Engine) -> int:
    """Touching pairs (centre distance < r_i + r_j) that are not in the engine's list."""
    start, nbr = build_neighbor_list(state.positions, state.radii, 0.0)
    touching = np.repeat(np.arange(state.n), np.diff(start)) * state.n + nbr
    i = np.repeat(np.arange(state.n), np.diff(engine._start))
    listed = np.minimum(i, engine._nbr) * state.n + np.maximum(i, engine._nbr)
    return int(np.count_nonzero(~np.isin(touching, listed)))


def test_kept_list_misses_no_contact_and_saves_builds() -> None:
    """Checked after every step of a 1 m/s plate pass: every touching pair is listed; the
    kept list saves builds the whole-bed rule makes."""
    builds = {}
    for local in (False, True):
        engine = Engine(PARAMS, box_walls(LO, HI, material=1), tool=_plate(),
                        local_rebuild=local)
        engine.REORDER_MIN = 0  # cell order (which the kept list needs) for a small bed
        missing = []

        def check(st: SimState, eng: Engine, missing: list[int] = missing) -> None:
            missing.append(_missing_contacts(st, eng))

        engine.run(_bed(), 300, tool_motion=_motion, callback=check)
        assert np.linalg.norm(engine.tool_force) > 0.01, 'the plate must push grains'
        assert sum(missing) == 0, f'{sum(missing)} contacts missing from the list'
        builds[local] = (engine.n_rebuilds, engine.kept_lists)
    print(f'builds (whole-bed rule, kept steps) {builds[False]}, kept list {builds[True]}')
    assert builds[False][1] == 0 and builds[True][1] > 0
    assert builds[True][0] < builds[False][0]
