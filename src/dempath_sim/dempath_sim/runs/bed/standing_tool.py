"""The tool standing in the bin while the bed is poured (``tool.placement: poured``).

LIGGGHTS users set a bin up with the tool already in it: ``insert/pack`` fills the bin at random,
``delete_atoms`` removes the grains that overlap the tool's mesh, and the bed falls and settles
around the tool (issue 12's hand-written deck). A bed poured without the tool and carved
afterwards (``tool.placement: carve``) has the same depth and density but another structure
next to the tool: on that deck's bin the side markers moved outward a fifth less. With
``poured`` the fill inserts the grains, removes those the tool at its start overlaps (its
closed mesh, as ``carve``) and settles and compacts the bed with the tool standing there.

The tool's start must not depend on the settled bed, so ``poured`` needs
``tool.depth_reference: nominal_surface`` (the scene loader says so). Such a packing belongs to
its tool and start: the packing key then includes them (`tool_key`).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from dempath_sim.engine import Engine, ToolPose, TriangleMesh
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.solid import overlapping_spheres
from dempath_sim.engine.state import SimState
from dempath_sim.runs.physics import TOOL, bin_walls
from dempath_sim.scene.spec import SceneSpec

POURED = 'poured'  # tool.placement value: the bed is poured around the standing tool


@dataclass(frozen=True)
class FillTool:
    """The tool as it stands during the fill: its mesh (tool frame) and tip position [m]."""

    mesh: TriangleMesh
    start: tuple[float, float, float]


def nominal_start(scene: SceneSpec) -> tuple[float, float, float]:
    """Tip position [m] below the nominal surface (what ``poured`` places the tool at)."""
    tool = scene.tool
    return (tool.x_m, -tool.depth_m + tool.settling_offset_m, tool.start_z_m)


def fill_tool(scene: SceneSpec) -> FillTool | None:
    """The tool standing in the bin during the fill, or None (it enters after the fill)."""
    if scene.tool.placement != POURED:
        return None
    mesh = TriangleMesh.from_stl(scene.tool.mesh, material=TOOL, scale=scene.tool.scale)
    return FillTool(mesh, nominal_start(scene))


def fill_engine(scene: SceneSpec, params: SimParams, tool: FillTool | None) -> Engine:
    """An engine of the bin's walls, and of the tool standing at its start when given."""
    if tool is None:
        return Engine(params, bin_walls(scene))
    engine = Engine(params, bin_walls(scene), tool.mesh)
    engine.tool_pose = ToolPose(np.asarray(tool.start, dtype=np.float64), np.zeros(3))
    return engine


def without_overlaps(state: SimState, tool: FillTool | None) -> SimState:
    """The inserted grains minus those the standing tool overlaps (``delete_atoms``)."""
    if tool is None:
        return state
    triangles = tool.mesh.triangles + np.asarray(tool.start, dtype=np.float64)
    return state.subset(~overlapping_spheres(triangles, state.positions, state.radii))


def tool_key(scene: SceneSpec) -> dict[str, object] | None:
    """What of the tool determines a ``poured`` packing (mesh bytes, scale, start), or None."""
    if scene.tool.placement != POURED:
        return None
    digest = hashlib.sha256(scene.tool.mesh.read_bytes()).hexdigest()
    return {'mesh': digest, 'scale': scene.tool.scale, 'start': list(nominal_start(scene))}
