"""Coulomb friction between particles (Mindlin-Deresiewicz tangential force, Coulomb limit)."""

from __future__ import annotations

from collections.abc import Mapping

from dempath_sim.effects._friction import apply_values, friction_parameters, set_friction
from dempath_sim.effects.base import Effect, PhysicsModel


class ParticleFriction(Effect):
    """Particle-particle sliding friction; off means frictionless grains."""

    name = 'particle_friction'
    description = 'Coulomb friction between particles (static and dynamic)'
    # Kuře & Kuřetová 2025, Table 6: static 0.71, dynamic 0.59 (DoE on the angle of repose).
    parameters = friction_parameters(0.71, 0.59, 'paper Table 6')

    def apply(self, model: PhysicsModel, values: Mapping[str, float]) -> PhysicsModel:
        return apply_values(model, 'particle', values, self.name)

    def apply_off(self, model: PhysicsModel) -> PhysicsModel:
        return set_friction(model, 'particle', 0.0, 0.0, self.name)


EFFECT = ParticleFriction()
