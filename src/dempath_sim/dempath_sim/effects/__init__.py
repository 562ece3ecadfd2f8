"""Registry of physical effects, discovered from the modules of this package.

Every public module here but ``base`` and ``candidates`` (the diagnosis's candidate table)
defines ``EFFECT``, an instance of :class:`~.base.Effect`; adding an effect means adding one
module. Other distributions can add effects through the entry-point
group ``dempath_sim.effects`` (``name = module:EFFECT``).

Example:
    >>> from dempath_sim.effects import all_effects
    >>> sorted(all_effects())[:3]
    ['cohesion', 'particle_friction', 'particle_size']
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Mapping
from functools import cache
from importlib.metadata import entry_points
from typing import Any

from dempath_sim.effects.base import ContactPair, Effect, ParameterSpec, PhysicsModel

__all__ = ['ContactPair', 'Effect', 'ParameterSpec', 'PhysicsModel', 'all_effects',
           'effect_table', 'get_effect']

ENTRY_POINT_GROUP = 'dempath_sim.effects'


@cache
def all_effects() -> dict[str, Effect]:
    """Every known effect by name, in alphabetical order."""
    found: dict[str, Effect] = {}
    for info in pkgutil.iter_modules(__path__):
        if info.name.startswith('_') or info.name in ('base', 'candidates'):
            continue
        module = importlib.import_module(f'{__name__}.{info.name}')
        effect = getattr(module, 'EFFECT', None)
        if isinstance(effect, Effect):
            found[effect.name] = effect
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        effect = ep.load()
        if isinstance(effect, Effect):
            found.setdefault(effect.name, effect)
    return dict(sorted(found.items()))


def get_effect(name: str) -> Effect:
    """The effect called ``name``; KeyError listing the known names otherwise."""
    effects = all_effects()
    if name not in effects:
        msg = f'unknown effect {name!r}; known: {", ".join(effects)}'
        raise KeyError(msg)
    return effects[name]


def effect_table(settings: Mapping[str, Any] | None = None) -> list[dict[str, Any]]:
    """One row per effect parameter, for tools that enumerate effects (the diagnosis, the CLI).

    Args:
        settings: ``SceneSpec.effects`` (name -> EffectSetting with ``enabled`` and ``values``)
            to report a scene's state; None for the defaults.

    Returns:
        Rows with keys effect, description, switchable, enabled, parameter, unit, low, high,
        default, value and doc.
    """
    rows = []
    for name, effect in all_effects().items():
        setting = settings[name] if settings is not None else None
        for spec in effect.parameters:
            rows.append({
                'effect': name, 'description': effect.description,
                'switchable': effect.switchable,
                'enabled': setting.enabled if setting else effect.default_enabled,
                'parameter': spec.name, 'unit': spec.unit, 'low': spec.low, 'high': spec.high,
                'default': spec.default,
                'value': setting.values[spec.name] if setting else spec.default,
                'doc': spec.doc})
    return rows
