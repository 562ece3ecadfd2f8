"""Young's modulus of the particles (stiffness of the Hertz normal and Mindlin tangential springs).

A DoE-calibrated, deliberately soft value (the paper's 1.70 MPa) keeps the Rayleigh time step
large; the macroscopic flow is insensitive to it over a wide range. Not switchable.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from dempath_sim.effects.base import Effect, ParameterSpec, PhysicsModel


class YoungsModulus(Effect):
    """Particle Young's modulus E."""

    name = 'youngs_modulus'
    description = "Young's modulus of the particles (contact stiffness, time step)"
    switchable = False
    parameters = (
        # Kuře & Kuřetová 2025, Table 6: 1.70 MPa (DoE range 1.70-10 MPa, Table 3).
        ParameterSpec('youngs_modulus_pa', 'Pa', 1.0e5, 1.0e11, 1.7e6,
                      "particle Young's modulus (paper Table 6)"),
    )

    def apply(self, model: PhysicsModel, values: Mapping[str, float]) -> PhysicsModel:
        return replace(model, particle_youngs_modulus_pa=values['youngs_modulus_pa'])


EFFECT = YoungsModulus()
