"""Rolling resistance of type C (linear spring with a rolling limit, EPSD2-like).

The rolling torque grows with a spring of stiffness k_r = 2.25 k_t mu_r^2 R*^2 and is limited to
mu_r R* |F_n| (Ai et al., Powder Technology 206 (2011) 269; Rocky DEM technical manual, type C;
LIGGGHTS rolling_friction epsd2). The coefficient acts on every contact pair.
"""

from __future__ import annotations

from collections.abc import Mapping

from dempath_sim.effects.base import Effect, ParameterSpec, PhysicsModel


class RollingResistance(Effect):
    """Rolling resistance coefficient mu_r on all contacts; off means free rolling."""

    name = 'rolling_resistance'
    description = 'Type C rolling resistance (linear spring, rolling limit mu_r R* F_n)'
    parameters = (
        # Kuře & Kuřetová 2025, Table 6: 0.26 (DoE range 0.10-0.26, Table 3).
        ParameterSpec('coefficient', '1', 0.0, 1.0, 0.26,
                      'rolling resistance coefficient mu_r (paper Table 6)'),
    )

    def apply(self, model: PhysicsModel, values: Mapping[str, float]) -> PhysicsModel:
        return model.with_pairs(rolling_resistance=values['coefficient'])

    def apply_off(self, model: PhysicsModel) -> PhysicsModel:
        return model.with_pairs(rolling_resistance=0.0)


EFFECT = RollingResistance()
