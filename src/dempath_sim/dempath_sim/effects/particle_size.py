"""Particle size by coarse graining: every layer's diameters times a factor.

Larger representative particles replace the fine grains with the same material and contact
parameters (Queteschiner et al., cited by the paper in Sec. 2.6.1); the two-layer bed of the
scene (fine top layer, coarse base) is kept. Not switchable; factor 1 is the scene's own sizes.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from dempath_sim.effects.base import Effect, ParameterSpec, PhysicsModel


class ParticleSize(Effect):
    """Coarse-graining factor on the layers' particle diameters."""

    name = 'particle_size'
    description = 'Coarse-graining factor on the particle diameters of every layer'
    switchable = False
    parameters = (
        ParameterSpec('coarse_grain', '1', 0.25, 8.0, 1.0,
                      'factor on every layer diameter (1: the scene sizes)'),
    )

    def apply(self, model: PhysicsModel, values: Mapping[str, float]) -> PhysicsModel:
        return replace(model, coarse_grain=values['coarse_grain'])


EFFECT = ParticleSize()
