"""Shared parts of the three Coulomb friction effects (particle, tool and wall pairs)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from dempath_sim.effects.base import ContactPair, ParameterSpec, PhysicsModel

PAIR_FIELDS = {'particle': 'particle_particle', 'tool': 'particle_tool', 'wall': 'particle_wall'}


def friction_parameters(static: float, dynamic: float, source: str) -> tuple[ParameterSpec, ...]:
    """Static and dynamic Coulomb coefficients with the defaults of ``source``."""
    return (
        ParameterSpec('static_friction', '1', 0.0, 2.0, static,
                      f'Coulomb coefficient for the onset of sliding ({source})'),
        ParameterSpec('dynamic_friction', '1', 0.0, 2.0, dynamic,
                      f'Coulomb coefficient while sliding, <= static ({source})'),
    )


def set_friction(model: PhysicsModel, pair: str, static: float, dynamic: float,
                 effect: str) -> PhysicsModel:
    """Return ``model`` with the friction of one pair set; dynamic must not exceed static."""
    if dynamic > static:
        msg = (f'{effect}.dynamic_friction: {dynamic!r} exceeds static_friction {static!r}; '
               'sliding friction cannot exceed the static coefficient')
        raise ValueError(msg)
    field = PAIR_FIELDS[pair]
    current: ContactPair = getattr(model, field)
    changes: dict[str, Any] = {field: replace(current, static_friction=static,
                                              dynamic_friction=dynamic)}
    return replace(model, **changes)


def apply_values(model: PhysicsModel, pair: str, values: Mapping[str, float],
                 effect: str) -> PhysicsModel:
    """Apply ``static_friction`` / ``dynamic_friction`` from ``values`` to one pair."""
    return set_friction(model, pair, values['static_friction'], values['dynamic_friction'],
                        effect)
