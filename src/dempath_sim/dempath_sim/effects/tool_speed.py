"""Tool speed: the scene's kinematic profile driven faster or slower.

Speeds scale by f and accelerations by f^2, so the phase distances of the profile stay as the
scene gives them (accelerate, steady, decelerate; see ``dempath_sim.scene.profiles``). Not
switchable.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from dempath_sim.effects.base import Effect, ParameterSpec, PhysicsModel


class ToolSpeed(Effect):
    """Factor on the tool's speed profile."""

    name = 'tool_speed'
    description = 'Factor on the tool speed profile (distances kept)'
    switchable = False
    parameters = (
        ParameterSpec('speed_scale', '1', 0.05, 4.0, 1.0,
                      'factor on all speeds of the profile (accelerations x factor^2)'),
    )

    def apply(self, model: PhysicsModel, values: Mapping[str, float]) -> PhysicsModel:
        return replace(model, speed_scale=values['speed_scale'])


EFFECT = ToolSpeed()
