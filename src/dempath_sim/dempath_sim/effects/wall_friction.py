"""Coulomb friction between particles and the bin walls and floor."""

from __future__ import annotations

from collections.abc import Mapping

from dempath_sim.effects._friction import apply_values, friction_parameters, set_friction
from dempath_sim.effects.base import Effect, PhysicsModel


class WallFriction(Effect):
    """Particle-wall sliding friction; off means frictionless bin walls and floor."""

    name = 'wall_friction'
    description = 'Coulomb friction between particles and the bin walls (static and dynamic)'
    # Kuře & Kuřetová 2025, Table 2, particles x boundary: static 0.40, dynamic 0.30.
    parameters = friction_parameters(0.40, 0.30, 'paper Table 2, particles x boundary')

    def apply(self, model: PhysicsModel, values: Mapping[str, float]) -> PhysicsModel:
        return apply_values(model, 'wall', values, self.name)

    def apply_off(self, model: PhysicsModel) -> PhysicsModel:
        return set_friction(model, 'wall', 0.0, 0.0, self.name)


EFFECT = WallFriction()
