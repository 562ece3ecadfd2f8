"""Coefficient of restitution of the Hertzian spring-dashpot normal force.

The dashpot coefficient follows from e (Tsuji et al., Powder Technology 71 (1992) 239; the
log-decrement form used by LIGGGHTS and Rocky). A model parameter, not switchable.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from dempath_sim.effects.base import Effect, ParameterSpec, PhysicsModel


class Restitution(Effect):
    """Normal restitution of particle-particle and particle-boundary contacts."""

    name = 'restitution'
    description = 'Normal coefficient of restitution (dashpot of the Hertz normal force)'
    switchable = False
    parameters = (
        # Kuře & Kuřetová 2025, Table 2: 0.30 for both pairs (Rocky default).
        ParameterSpec('particle_particle', '1', 0.01, 1.0, 0.30,
                      'restitution between particles (paper Table 2)'),
        ParameterSpec('particle_boundary', '1', 0.01, 1.0, 0.30,
                      'restitution between particles and tool/walls (paper Table 2)'),
    )

    def apply(self, model: PhysicsModel, values: Mapping[str, float]) -> PhysicsModel:
        eb = values['particle_boundary']
        return replace(
            model,
            particle_particle=replace(model.particle_particle,
                                      restitution=values['particle_particle']),
            particle_tool=replace(model.particle_tool, restitution=eb),
            particle_wall=replace(model.particle_wall, restitution=eb))


EFFECT = Restitution()
