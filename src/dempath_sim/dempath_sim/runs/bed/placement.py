"""The tool in the bed: where its tip starts and which particles make room for it.

``tool.placement: carve`` (the default) removes the particles that overlap the tool's own
volume, as a LIGGGHTS deck does when it deletes the atoms overlapping the inserted mesh (and as
a lab pushes the tine into the sand): a particle goes when its centre lies inside the closed
mesh (generalised winding number, ``engine.solid``) or its sphere cuts the mesh surface.
``tool.placement: slot`` removes every particle touching the tool's bounding box, a pre-cut slot
(dempath's set-up before issue 12): for a leaning tine it also empties the wedge behind the
share. ``tool.placement: poured``: the bed was poured and settled around the standing tool
(``runs.bed.standing_tool``), so the grains resting against it stay (their contact overlap is the
bed's); only a centre inside the mesh would go, as none should. The carve needs a closed mesh;
an open one stops with one error naming the STL.
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.engine.solid import open_edges, overlapping_spheres, winding_numbers
from dempath_sim.engine.state import SimState
from dempath_sim.errors import GeometryError
from dempath_sim.runs.bed.measure import FillReport
from dempath_sim.runs.bed.standing_tool import nominal_start
from dempath_sim.scene.spec import SceneSpec

logger = logging.getLogger(__name__)

# tool.placement: overlap with the mesh / its bounding box / bed poured around the tool
PLACEMENTS = ('carve', 'slot', 'poured')


def tool_start(scene: SceneSpec, fill: FillReport) -> tuple[float, float, float]:
    """Tip position at time 0 [m]: depth below the settled (or nominal, offset) surface."""
    tool = scene.tool
    if tool.depth_reference == 'settled_surface':
        return (tool.x_m, fill.surface_height_m - tool.depth_m, tool.start_z_m)
    return nominal_start(scene)


def slot_mask(positions: NDArray[np.float64], radii: NDArray[np.float64],
              triangles: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(n,) bool: spheres touching the bounding box of ``triangles`` (n_tri, 3, 3) [m]."""
    flat = triangles.reshape(-1, 3)
    lo, hi = flat.min(axis=0), flat.max(axis=0)
    r = radii[:, None]
    inside: NDArray[np.bool_] = np.all((positions > lo - r) & (positions < hi + r), axis=1)
    return inside


def check_closed(mesh: TriangleMesh) -> None:
    """Raise GeometryError naming the mesh when it has open edges (no inside to carve)."""
    bad = open_edges(mesh.triangles)
    if bad:
        msg = (f'{mesh.name}: the tool mesh is not closed ({bad} open or inconsistently '
               'oriented edges), so the carve cannot tell inside from outside; close the mesh '
               'or set tool.placement: slot')
        raise GeometryError(msg)


def removal_mask(positions: NDArray[np.float64], radii: NDArray[np.float64],
                 mesh: TriangleMesh, start: tuple[float, float, float],
                 placement: str = 'carve') -> NDArray[np.bool_]:
    """(n,) bool: the particles the tool at ``start`` displaces under ``placement``.

    Raises:
        GeometryError: ``carve`` with a mesh that is not closed.
        ValueError: An unknown placement.
    """
    triangles = mesh.triangles + np.asarray(start, dtype=np.float64)
    if placement == 'slot':
        return slot_mask(positions, radii, triangles)
    if placement not in PLACEMENTS:
        msg = f'tool placement must be one of {PLACEMENTS}, got {placement!r}'
        raise ValueError(msg)
    check_closed(mesh)
    if placement == 'poured':
        inside = slot_mask(positions, np.zeros(len(positions)), triangles)
        near = np.flatnonzero(inside)
        inside[near] = np.abs(winding_numbers(positions[near], triangles)) > 0.5
        return inside
    return overlapping_spheres(triangles, positions, radii)


def place_tool(state: SimState, mesh: TriangleMesh, start: tuple[float, float, float],
               placement: str = 'carve') -> tuple[SimState, int]:
    """The bed without the particles the tool displaces, and how many were removed."""
    gone = removal_mask(state.positions, state.radii, mesh, start, placement)
    logger.info('tool placement (%s): removed %d particles', placement, int(gone.sum()))
    return state.subset(~gone), int(gone.sum())


def carve_tool_slot(state: SimState, mesh: TriangleMesh,
                    start: tuple[float, float, float]) -> SimState:
    """Remove the particles that touch the tool's bounding box at its start (the slot)."""
    return place_tool(state, mesh, start, 'slot')[0]


__all__ = ['PLACEMENTS', 'carve_tool_slot', 'check_closed', 'place_tool', 'removal_mask',
           'slot_mask', 'tool_start']
