"""Materials and per-pair interaction coefficients of the DEM engine.

A `Material` holds the bulk properties of one solid (particles, bin walls or tool); an
`Interaction` holds the coefficients of one pair of materials (restitution, friction, rolling
resistance, cohesion), as in the paper's Tables 2 and 6 (Technologies 2025, 13, 570).
`pair_properties` combines two materials into the effective moduli that the contact laws use.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


def _check_positive(owner: str, name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        msg = f'{owner}.{name} must be a finite number > 0, got {value!r}'
        raise ValueError(msg)


def _check_range(owner: str, name: str, value: float, lo: float, hi: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and lo <= value <= hi):
        msg = f'{owner}.{name} must be in [{lo}, {hi}], got {value!r}'
        raise ValueError(msg)


@dataclass(frozen=True)
class Material:
    """Bulk properties of one solid.

    Attributes:
        name: Label used in messages and scene files.
        density: Solid (particle) density [kg/m^3].
        youngs_modulus: Young's modulus E [Pa].
        poisson_ratio: Poisson's ratio nu [-], in [0, 0.5).
    """

    name: str
    density: float
    youngs_modulus: float
    poisson_ratio: float

    def __post_init__(self) -> None:
        """Validate every field; raise ValueError naming the field and its value."""
        owner = f'Material({self.name!r})'
        _check_positive(owner, 'density', self.density)
        _check_positive(owner, 'youngs_modulus', self.youngs_modulus)
        _check_range(owner, 'poisson_ratio', self.poisson_ratio, 0.0, 0.4999)

    @property
    def shear_modulus(self) -> float:
        """Shear modulus G = E / (2 (1 + nu)) [Pa]."""
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))


@dataclass(frozen=True)
class Interaction:
    """Contact coefficients of one pair of materials (symmetric).

    Attributes:
        restitution: Normal coefficient of restitution e [-], in (0, 1].
        static_friction: Coulomb coefficient for sticking mu_s [-], >= dynamic_friction.
        dynamic_friction: Coulomb coefficient while sliding mu_d [-].
        rolling_resistance: Rolling resistance coefficient mu_r [-] (EPSD2 / type C); 0 = off
            (the effect ``rolling_resistance``; LIGGGHTS' ``coefficientRollingFriction``).
        cohesion_energy_density: SJKR cohesion energy density k_c [J/m^3]; 0 = off.
    """

    restitution: float
    static_friction: float
    dynamic_friction: float
    rolling_resistance: float = 0.0
    cohesion_energy_density: float = 0.0

    def __post_init__(self) -> None:
        """Validate every field; raise ValueError naming the field and its value."""
        owner = 'Interaction'
        _check_range(owner, 'restitution', self.restitution, 1e-6, 1.0)
        _check_range(owner, 'static_friction', self.static_friction, 0.0, 10.0)
        _check_range(owner, 'dynamic_friction', self.dynamic_friction, 0.0, 10.0)
        _check_range(owner, 'rolling_resistance', self.rolling_resistance, 0.0, 10.0)
        _check_range(owner, 'cohesion_energy_density', self.cohesion_energy_density, 0.0, 1e12)
        if self.dynamic_friction > self.static_friction:
            msg = (f'Interaction.dynamic_friction ({self.dynamic_friction!r}) must not exceed '
                   f'static_friction ({self.static_friction!r})')
            raise ValueError(msg)

    @property
    def damping_beta(self) -> float:
        """Damping ratio beta = -ln e / sqrt(ln^2 e + pi^2) >= 0 [-].

        The Hertzian dashpot gamma_n = 2 sqrt(5/6) beta sqrt(S_n m*) with this beta gives a
        velocity-independent restitution equal to e (Antypov & Elliott, EPL 94 (2011) 50004;
        the same form as LIGGGHTS `model hertz`). 0 for e = 1.
        """
        log_e = math.log(self.restitution)
        return -log_e / math.sqrt(log_e * log_e + math.pi * math.pi)


@dataclass(frozen=True)
class PairProperties:
    """Effective moduli of a material pair used by the Hertz-Mindlin laws.

    Attributes:
        effective_youngs: E* = 1 / ((1 - nu1^2)/E1 + (1 - nu2^2)/E2) [Pa].
        effective_shear: G* = 1 / ((2 - nu1)/G1 + (2 - nu2)/G2) [Pa].
    """

    effective_youngs: float
    effective_shear: float


def pair_properties(a: Material, b: Material) -> PairProperties:
    """Combine two materials into the effective Hertz-Mindlin moduli.

    Formula: Johnson, Contact Mechanics (1985), eqs. 4.22 and 7.33 (Mindlin).

    Args:
        a: First material.
        b: Second material.

    Returns:
        The effective Young's and shear moduli [Pa].
    """
    e_star = 1.0 / ((1.0 - a.poisson_ratio ** 2) / a.youngs_modulus
                    + (1.0 - b.poisson_ratio ** 2) / b.youngs_modulus)
    g_star = 1.0 / ((2.0 - a.poisson_ratio) / a.shear_modulus
                    + (2.0 - b.poisson_ratio) / b.shear_modulus)
    return PairProperties(effective_youngs=e_star, effective_shear=g_star)
