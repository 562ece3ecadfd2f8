"""The effects library's candidates as variants of a scene, for checks across engines.

A cross-engine check that passes for the baseline physics says little about the diagnosis: the
diagnosis names the effect whose signature fits, so each signature must transfer between the
engines too. A variant changes one candidate of the library the way the signature library runs
it (``dempath_diagnose.library``; both read ``effects.candidates``): an effect the scene has off
is switched on at 5x its default strength, a parameter (or an effect that is on) is moved to
1.5x its value (Young's modulus: 3x; ``STRENGTHS``, 'upper'; 'lower': 1x, 0.6x, 0.3x), the
parameters linked to it scaled alike (dynamic with static friction, the boundary's
restitution with the particles'). Contact effects switched on act between grains only
(``boundary_fraction`` 0), as a deck's pair style does when its wall and tool fixes leave them
out.

Every variant keeps the scene's bed physics: the bed is poured once with the scene file's
effects and each variant re-settles it with its own physics, tool in place (``tool.settle_s``),
on both engines alike.
"""

from __future__ import annotations

from dempath_sim.effects import all_effects
from dempath_sim.effects.candidates import (
    CANDIDATES,
    EFFECT_FACTORS,
    LINKED,
    LOG_FACTORS,
    LOG_SCALE,
    MAIN_PARAMETER,
    PARAMETER_FACTORS,
)
from dempath_sim.scene.spec import SceneSpec

# Strength -> (effect factor, parameter factor, log factor): the signature library's strongest
# and weakest runs of a candidate (``effects.candidates``), so what it runs is what is checked.
STRENGTHS = {'upper': (max(EFFECT_FACTORS), max(PARAMETER_FACTORS), max(LOG_FACTORS)),
             'lower': (min(EFFECT_FACTORS), min(PARAMETER_FACTORS), min(LOG_FACTORS))}
VARIANTS = ('base', *CANDIDATES)


def variant_overrides(scene: SceneSpec, name: str, strength: str = 'upper',
                      ) -> tuple[dict[str, float], tuple[str, ...]]:
    """Scene overrides ``({'effect.parameter': value}, effects switched on)`` of one variant.

    Args:
        scene: The scene the variant changes.
        name: One of ``VARIANTS``.
        strength: ``'upper'`` (the library's strongest run of the candidate, the default) or
            ``'lower'`` (its weakest: an effect that is off at its default strength, a
            parameter x0.6, Young's modulus x0.3).

    Raises:
        ValueError: ``name`` is not one of ``VARIANTS`` or ``strength`` not one of
            ``STRENGTHS``.
    """
    if name not in VARIANTS:
        msg = f'variant: {name!r} is not one of {", ".join(VARIANTS)}'
        raise ValueError(msg)
    if strength not in STRENGTHS:
        msg = f'variant strength: {strength!r} is not one of {", ".join(STRENGTHS)}'
        raise ValueError(msg)
    effect_factor, parameter_factor, log_factor = STRENGTHS[strength]
    if name == 'base':
        return {}, ()
    setting = scene.effects[name]
    main = MAIN_PARAMETER[name]
    if not setting.enabled:
        default = all_effects()[name].parameter(main).default
        values = {f'{name}.{main}': effect_factor * default}
        if 'boundary_fraction' in setting.values:
            values[f'{name}.boundary_fraction'] = 0.0
        return values, (name,)
    factor = log_factor if name in LOG_SCALE else parameter_factor
    values = {f'{name}.{main}': factor * float(setting.values[main])}
    for linked in LINKED.get(main, ()):
        if linked in setting.values:
            values[f'{name}.{linked}'] = factor * float(setting.values[linked])
    return values, ()


def variant_scene(scene: SceneSpec, name: str, strength: str = 'upper') -> SceneSpec:
    """``scene`` with one variant's physics (its bed physics kept: see the module docstring)."""
    values, on = variant_overrides(scene, name, strength)
    return scene.with_overrides(values, on=on) if values or on else scene
