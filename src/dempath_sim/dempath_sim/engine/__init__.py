"""The DEM engine: a state record, parameters and a velocity-Verlet step made of named stages.

Soft spheres, plane walls and a kinematic triangle-mesh tool; no scene, no run (those are
`dempath_sim.scene` and `dempath_sim.runs`). The contact laws are one module each in
`dempath_sim.engine.laws`, as LAMMPS / LIGGGHTS keep one file per pair style; the kernels
(`pair_forces.py`, `boundary.py`) inline them through `laws.dispatch`.
"""

from __future__ import annotations

from dempath_sim.engine.energy import elastic_energy, total_energy
from dempath_sim.engine.engine import Engine
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.engine.params import (
    CONTACT_FORMS,
    COULOMB_LIMITS,
    DEFAULT_MAX_OVERLAP_FRACTION,
    SimParams,
)
from dempath_sim.engine.sleep import SleepSettings
from dempath_sim.engine.state import SimState
from dempath_sim.engine.stl import read_stl
from dempath_sim.engine.timestep import rayleigh_time_step
from dempath_sim.engine.toolpose import ToolPose
from dempath_sim.engine.walls import Plane, box_walls

__all__ = [
           'CONTACT_FORMS',
           'COULOMB_LIMITS',
           'DEFAULT_MAX_OVERLAP_FRACTION',
           'Engine',
           'Interaction',
           'Material',
           'Plane',
           'SimParams',
           'SimState',
           'SleepSettings',
           'ToolPose',
           'TriangleMesh',
           'box_walls',
           'elastic_energy',
           'rayleigh_time_step',
           'read_stl',
           'total_energy',
]
