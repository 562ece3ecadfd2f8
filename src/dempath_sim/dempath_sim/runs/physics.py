"""The scene -> engine-parameter build that both backends use (dempath's engine and LIGGGHTS).

A scene's physics model (``SceneSpec.physics_model()``: materials with every effect applied)
becomes `SimParams` with three materials at fixed indices, PARTICLES, WALLS and TOOL, and their
three interactions; the bin becomes five plane walls (open top). The LIGGGHTS decks are written
from the same `SimParams`, so both engines run the same coefficients.
"""

from __future__ import annotations

from dataclasses import replace

from dempath_sim.effects import ContactPair, PhysicsModel
from dempath_sim.engine import Interaction, Material, Plane, SimParams, box_walls
from dempath_sim.scene import SceneSpec

PARTICLES, WALLS, TOOL = 0, 1, 2  # material indices used by the runs
DOMAIN_MARGIN_M = 0.2  # the domain box reaches this far beyond the bin walls [m]


def _interaction(pair: ContactPair) -> Interaction:
    return Interaction(restitution=pair.restitution, static_friction=pair.static_friction,
                       dynamic_friction=pair.dynamic_friction,
                       rolling_resistance=pair.rolling_resistance,
                       cohesion_energy_density=pair.cohesion_energy_density_j_m3)


def build_params(scene: SceneSpec, model: PhysicsModel) -> SimParams:
    """Engine parameters: materials PARTICLES, WALLS, TOOL and their three interactions."""
    walls = scene.materials['walls']
    materials = (
        Material('particles', model.particle_density_kg_m3, model.particle_youngs_modulus_pa,
                 model.particle_poisson),
        Material('walls', walls.density_kg_m3, model.wall_youngs_modulus_pa, model.wall_poisson),
        Material('tool', model.tool_density_kg_m3, model.tool_youngs_modulus_pa,
                 model.tool_poisson))
    floor = -scene.bed_thickness_m
    w, m = scene.bin.width_x_m / 2, DOMAIN_MARGIN_M
    return SimParams(
        materials=materials,
        interactions={(PARTICLES, PARTICLES): _interaction(model.particle_particle),
                      (PARTICLES, WALLS): _interaction(model.particle_wall),
                      (PARTICLES, TOOL): _interaction(model.particle_tool)},
        dt=scene.sim.time_step_s, rayleigh_safety=scene.sim.rayleigh_safety,
        max_overlap_fraction=scene.sim.max_overlap_fraction,
        coulomb_limit=scene.sim.coulomb_limit, contact_forms=scene.sim.contact_forms,
        domain_min=(-w - m, floor - m, -m),
        domain_max=(w + m, floor + scene.bin.height_y_m + 2.0, scene.bin.length_z_m + m))


def bin_walls(scene: SceneSpec) -> tuple[Plane, ...]:
    """Floor and four side walls of the bin (open top), material WALLS."""
    w, floor = scene.bin.width_x_m / 2, -scene.bed_thickness_m
    return box_walls((-w, floor, 0.0), (w, floor + scene.bin.height_y_m, scene.bin.length_z_m),
                     material=WALLS, open_top=True)


def scaled_friction(params: SimParams, factor: float) -> SimParams:
    """``params`` with friction and rolling resistance of every pair times ``factor``."""
    table = {key: replace(x, static_friction=x.static_friction * factor,
                          dynamic_friction=x.dynamic_friction * factor,
                          rolling_resistance=x.rolling_resistance * factor)
             for key, x in params.interactions.items()}
    return replace(params, interactions=table)
