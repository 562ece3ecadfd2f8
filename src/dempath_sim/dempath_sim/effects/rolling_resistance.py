"""Rolling resistance of type C (linear spring with a rolling limit, EPSD2-like).

The rolling torque grows with a spring of stiffness k_r = 2.25 k_t mu_r^2 R*^2 and is limited to
mu_r R* |F_n| (Ai et al., Powder Technology 206 (2011) 269; Rocky DEM technical manual, type C;
LIGGGHTS rolling_friction epsd2). The coefficient acts between particles and, scaled by
``boundary_fraction``, towards the tool and the walls: 1 (the default) applies mu_r to every
contact, as Rocky's rolling resistance, a particle property, does; 0 limits it to
particle-particle contacts, as a LIGGGHTS deck whose wall fixes leave ``rolling_friction`` out
(or set coefficientRollingFriction 0 for the wall types) does.
"""

from __future__ import annotations

from collections.abc import Mapping

from dempath_sim.effects.base import Effect, ParameterSpec, PhysicsModel


class RollingResistance(Effect):
    """Rolling resistance coefficient mu_r between particles (and, scaled, towards tool and
    walls); off means free rolling."""

    name = 'rolling_resistance'
    description = 'Type C rolling resistance (linear spring, rolling limit mu_r R* F_n)'
    parameters = (
        # Kuře & Kuřetová 2025, Table 6: 0.26 (DoE range 0.10-0.26, Table 3).
        ParameterSpec('coefficient', '1', 0.0, 1.0, 0.26,
                      'rolling resistance coefficient mu_r (paper Table 6)'),
        # 1: Rocky applies a particle's rolling resistance to every contact (the paper's
        # model); 0: particle pairs only, as LIGGGHTS decks that leave it off the walls.
        ParameterSpec('boundary_fraction', '1', 0.0, 1.0, 1.0,
                      'mu_r towards the tool and walls as a fraction of the particle value '
                      '(1: every contact, as Rocky; 0: particle pairs only)'),
    )

    def apply(self, model: PhysicsModel, values: Mapping[str, float]) -> PhysicsModel:
        mu_r = values['coefficient']
        return model.with_scoped('rolling_resistance', mu_r, mu_r * values['boundary_fraction'])

    def apply_off(self, model: PhysicsModel) -> PhysicsModel:
        return model.with_pairs(rolling_resistance=0.0)


EFFECT = RollingResistance()
