"""The effect protocol and the physics model that effects act on.

An effect is one switchable piece of physics (rolling resistance, cohesion, tool friction...)
with named parameters in SI units and physical ranges. ``Effect.apply`` maps the effect's
parameter values onto a :class:`PhysicsModel` (material and contact-pair parameters, coarse
graining, tool speed scale); ``Effect.apply_off`` writes the values that mean "effect absent".
The run turns the final model into engine parameters, so a new effect that acts through existing
model fields is one new module in this package and no engine change.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import ClassVar


@dataclass(frozen=True)
class ParameterSpec:
    """One named parameter of an effect.

    Attributes:
        name: Key in the scene file, with the SI unit as suffix when dimensional
            (``energy_density_j_m3``); plain coefficients have no suffix.
        unit: SI unit as text (``J/m^3``, ``Pa``, ``1`` for dimensionless).
        low: Smallest physically meaningful value (inclusive).
        high: Largest physically meaningful value (inclusive).
        default: Value used when the scene does not set it (the paper's value where it has one).
        doc: One line on what it is and where the default comes from.
    """

    name: str
    unit: str
    low: float
    high: float
    default: float
    doc: str

    def __post_init__(self) -> None:
        if not self.low <= self.default <= self.high:
            msg = f'ParameterSpec {self.name!r}: default {self.default!r} outside [low, high]'
            raise ValueError(msg)

    def check(self, value: float, where: str) -> float:
        """Return ``value`` as float or raise ValueError naming ``where`` and the range."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            msg = f'{where}: expected a number in {self.unit}, got {value!r}'
            raise ValueError(msg)
        x = float(value)
        if not (math.isfinite(x) and self.low <= x <= self.high):
            msg = (f'{where}: {x!r} {self.unit} is outside the physical range '
                   f'[{self.low:g}, {self.high:g}] {self.unit}')
            raise ValueError(msg)
        return x


@dataclass(frozen=True)
class ContactPair:
    """Contact parameters of one pair of materials.

    Attributes:
        static_friction: Coulomb coefficient for the onset of sliding [1].
        dynamic_friction: Coulomb coefficient while sliding [1].
        restitution: Normal coefficient of restitution [1].
        rolling_resistance: Rolling resistance coefficient of the type C / EPSD2 model [1].
        cohesion_energy_density_j_m3: SJKR cohesion energy density k, F = k A_contact [J/m^3].
    """

    static_friction: float
    dynamic_friction: float
    restitution: float
    rolling_resistance: float = 0.0
    cohesion_energy_density_j_m3: float = 0.0


@dataclass(frozen=True)
class PhysicsModel:
    """Everything the effects can change, before it becomes engine parameters.

    Attributes:
        particle_density_kg_m3: Solid density of the particle material [kg/m^3].
        particle_youngs_modulus_pa: Young's modulus of the particles [Pa].
        particle_poisson: Poisson's ratio of the particles [1].
        tool_density_kg_m3: Density of the tool material [kg/m^3] (steel).
        tool_youngs_modulus_pa: Young's modulus of the tool [Pa].
        tool_poisson: Poisson's ratio of the tool [1].
        wall_youngs_modulus_pa: Young's modulus of the bin walls [Pa].
        wall_poisson: Poisson's ratio of the bin walls [1].
        particle_particle: Contact parameters between particles.
        particle_tool: Contact parameters between particles and the tool.
        particle_wall: Contact parameters between particles and the bin walls.
        coarse_grain: Factor on every layer's particle diameters [1].
        speed_scale: Factor on the tool's speeds (distances kept, accelerations x f^2) [1].
    """

    particle_density_kg_m3: float
    particle_youngs_modulus_pa: float
    particle_poisson: float
    tool_density_kg_m3: float
    tool_youngs_modulus_pa: float
    tool_poisson: float
    wall_youngs_modulus_pa: float
    wall_poisson: float
    particle_particle: ContactPair
    particle_tool: ContactPair
    particle_wall: ContactPair
    coarse_grain: float = 1.0
    speed_scale: float = 1.0

    def with_pairs(self, **changes: float) -> PhysicsModel:
        """Set the same contact fields on all three pairs (e.g. ``rolling_resistance=0.26``)."""
        return replace(self, particle_particle=replace(self.particle_particle, **changes),
                       particle_tool=replace(self.particle_tool, **changes),
                       particle_wall=replace(self.particle_wall, **changes))

    def with_scoped(self, name: str, particles: float, boundary: float) -> PhysicsModel:
        """Set contact field ``name`` to ``particles`` between particles and to ``boundary``
        towards the tool and the walls (an effect's scope, e.g. ``boundary_fraction``)."""
        return replace(
            self, particle_particle=replace(self.particle_particle, **{name: particles}),
            particle_tool=replace(self.particle_tool, **{name: boundary}),
            particle_wall=replace(self.particle_wall, **{name: boundary}))


class Effect(ABC):
    """One switchable piece of physics with named, ranged parameters.

    Subclasses set the class attributes and implement :meth:`apply`; switchable effects also
    implement :meth:`apply_off`. Each module of ``dempath_sim.effects`` defines ``EFFECT``.
    """

    name: ClassVar[str]
    description: ClassVar[str]
    parameters: ClassVar[tuple[ParameterSpec, ...]]
    switchable: ClassVar[bool] = True  # False: the effect is a model parameter that cannot be off
    default_enabled: ClassVar[bool] = True  # state when a scene does not mention the effect

    def parameter(self, name: str) -> ParameterSpec:
        """The parameter called ``name``; KeyError when the effect has none."""
        for spec in self.parameters:
            if spec.name == name:
                return spec
        raise KeyError(name)

    def defaults(self) -> dict[str, float]:
        """Default value of every parameter."""
        return {p.name: p.default for p in self.parameters}

    @abstractmethod
    def apply(self, model: PhysicsModel, values: Mapping[str, float]) -> PhysicsModel:
        """Return ``model`` with this effect on at parameter ``values`` (all parameters given)."""

    def apply_off(self, model: PhysicsModel) -> PhysicsModel:
        """Return ``model`` with this effect absent (only for switchable effects)."""
        msg = f'effect {self.name!r} cannot be switched off'
        raise ValueError(msg)
