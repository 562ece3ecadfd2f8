"""Run set-up without stepping: engine parameters, tool placement and the tool slot."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.engine.state import SimState
from dempath_sim.runs.bed import FillReport
from dempath_sim.runs.native import carve_tool_slot, tool_start
from dempath_sim.runs.physics import PARTICLES, TOOL, WALLS, build_params
from dempath_sim.scene import bundled_scene


def report(surface: float) -> FillReport:
    """A fill report with the given surface height."""
    return FillReport(100, 1040.0, 0.6, surface, -0.76, None, True, 1.0, True, 'k')


def test_params_carry_the_paper_tables() -> None:
    """Materials and pair interactions of the paper scene reach SimParams."""
    scene = bundled_scene('paper_1ms')
    params = build_params(scene, scene.physics_model())
    assert params.materials[PARTICLES].youngs_modulus == pytest.approx(1.7e6)
    assert params.materials[TOOL].density == 7800
    pp, pt = params.interaction(PARTICLES, PARTICLES), params.interaction(PARTICLES, TOOL)
    assert (pp.static_friction, pp.dynamic_friction, pp.rolling_resistance) == (0.71, 0.59, 0.26)
    assert (pt.static_friction, pt.dynamic_friction, pt.restitution) == (0.40, 0.30, 0.30)
    assert params.interaction(PARTICLES, WALLS).static_friction == 0.40
    assert params.domain_min[1] < -scene.bed_thickness_m


def test_tool_depth_references() -> None:
    """184 mm below the settled surface, or below Y = 0 shifted by the -17 mm offset."""
    scene = bundled_scene('paper_1ms')
    assert tool_start(scene, report(0.012)) == pytest.approx((0.0, 0.012 - 0.184, 0.3))
    nominal = replace(scene, tool=replace(scene.tool, depth_reference='nominal_surface'))
    assert tool_start(nominal, report(0.012)) == pytest.approx((0.0, -0.184 - 0.017, 0.3))


def test_tool_slot_removes_particles_in_the_tool_box() -> None:
    """Exactly the particles touching the tool's bounding box at its start are removed."""
    scene = bundled_scene('tiny')
    params = build_params(scene, scene.physics_model())
    mesh = TriangleMesh.from_stl(scene.tool.mesh, material=TOOL, scale=0.5)
    rng = np.random.default_rng(4)
    pos = rng.uniform((-0.07, -0.05, 0.0), (0.07, 0.0, 0.22), (400, 3))
    state = SimState.from_spheres(pos, 0.003, PARTICLES, params)
    start = (0.0, -0.03, 0.1)
    kept = carve_tool_slot(state, mesh, start)
    lo, hi = mesh.bounds
    inside = np.all((pos > lo + start - 0.003) & (pos < hi + start + 0.003), axis=1)
    assert kept.n == 400 - inside.sum() and inside.any()
    np.testing.assert_array_equal(kept.ids, state.ids[~inside])
