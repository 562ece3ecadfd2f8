"""Moisture-like cohesion, simplified JKR (SJKR): F_c = k A_contact.

A contact of overlap area A_contact = pi a^2 (a the Hertz contact radius) attracts with
k A_contact, k the cohesion energy density [J/m^3] (LIGGGHTS cohesion sjkr; Johnson, Kendall &
Roberts, Proc. R. Soc. A 324 (1971) 301). The paper neglected adhesion for its dry sand
(moisture 0.88 %, Sec. 2.1 and 2.6.1), so the shipped scenes leave it off.
"""

from __future__ import annotations

from collections.abc import Mapping

from dempath_sim.effects.base import Effect, ParameterSpec, PhysicsModel


class Cohesion(Effect):
    """SJKR cohesion between particles (and optionally towards tool and walls)."""

    name = 'cohesion'
    description = 'Moisture-like cohesion, SJKR: F = k * contact area'
    default_enabled = False
    parameters = (
        ParameterSpec('energy_density_j_m3', 'J/m^3', 0.0, 1.0e6, 2.0e4,
                      'cohesion energy density k between particles (moist sand ~1e4-1e5)'),
        ParameterSpec('boundary_fraction', '1', 0.0, 1.0, 0.0,
                      'k towards the tool and walls as a fraction of the particle value'),
    )

    def apply(self, model: PhysicsModel, values: Mapping[str, float]) -> PhysicsModel:
        k = values['energy_density_j_m3']
        return model.with_scoped('cohesion_energy_density_j_m3', k,
                                 k * values['boundary_fraction'])

    def apply_off(self, model: PhysicsModel) -> PhysicsModel:
        return model.with_pairs(cohesion_energy_density_j_m3=0.0)


EFFECT = Cohesion()
