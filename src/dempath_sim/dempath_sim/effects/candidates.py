"""The effects the diagnosis considers as candidates, and the strengths it runs them at.

One table for the two places that need it: the signature library of ``dempath_diagnose`` (which
runs every candidate at these strengths to learn its signature) and the cross-engine variants of
``dempath_sim.validation.effect_variants`` (which check that each signature transfers to
LIGGGHTS). A candidate is an effect the scene has off (switched on at ``EFFECT_FACTORS`` x its
default strength) or one that is on, whose strength may be off in either direction (moved to
``PARAMETER_FACTORS`` x its value, ``LOG_FACTORS`` for the ``LOG_SCALE`` ones).
"""

from __future__ import annotations

from types import MappingProxyType

CANDIDATES = ('cohesion', 'rolling_resistance', 'tool_friction', 'tool_speed',
              'particle_friction', 'youngs_modulus', 'restitution')
# Main parameter of each effect: the one whose value is the candidate's strength.
MAIN_PARAMETER = MappingProxyType({
    'cohesion': 'energy_density_j_m3', 'rolling_resistance': 'coefficient',
    'tool_friction': 'static_friction', 'particle_friction': 'static_friction',
    'wall_friction': 'static_friction', 'tool_speed': 'speed_scale',
    'youngs_modulus': 'youngs_modulus_pa', 'restitution': 'particle_particle',
    'particle_size': 'coarse_grain'})
# Parameters scaled together with the main one (kept in the scene's proportion).
LINKED = MappingProxyType({'static_friction': ('dynamic_friction',),
                           'particle_particle': ('particle_boundary',)})
LOG_SCALE = frozenset({'youngs_modulus'})  # strengths spread by factors, not steps
EFFECT_FACTORS = (5.0, 1.0)  # an effect that is off: its default x these (first if one)
PARAMETER_FACTORS = (0.6, 1.5)  # a parameter that is on: its value x these
LOG_FACTORS = (0.3, 3.0)
