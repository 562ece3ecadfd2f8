"""Hertz-Mindlin contact references: analytic contact time and a damped-contact ODE.

Normal force of the engines (LIGGGHTS ``model hertz``; Di Renzo & Di Maio 2004; Antypov &
Elliott 2011):

    F_n = 4/3 E* sqrt(R* d) d + 2 sqrt(5/6) beta sqrt(S_n m*) d',  S_n = 2 E* sqrt(R* d),
    beta = -ln e / sqrt(ln^2 e + pi^2)

For e = 1 the contact lasts t_c = 2.9432 d_max / v with d_max = (15 m* v^2 / (16 E* sqrt(R*)))^0.4
(Johnson, Contact Mechanics, 1985, sec. 11.4). For e < 1 the same ODE is integrated with
scipy to 1e-10 relative tolerance (the semi-analytic reference for duration and rebound).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

# The integral of (1 - x^2.5)^-0.5 from 0 to 1, times 2: t_c = HERTZ_TIME_FACTOR d_max / v.
HERTZ_TIME_FACTOR = 2.9432


@dataclass(frozen=True)
class HertzPair:
    """Effective quantities of a two-body contact.

    Attributes:
        e_star: Effective Young's modulus E* [Pa].
        r_star: Effective radius R* [m].
        m_star: Effective mass m* [kg].
        restitution: Coefficient of restitution e [-].
    """

    e_star: float
    r_star: float
    m_star: float
    restitution: float

    @property
    def beta(self) -> float:
        """Damping ratio beta(e) [-] (0 for e = 1)."""
        log_e = math.log(self.restitution)
        return -log_e / math.sqrt(log_e * log_e + math.pi * math.pi)


def sphere_pair(radius: float, density: float, youngs: float, poisson: float,
                restitution: float) -> HertzPair:
    """Two identical spheres: R* = R/2, m* = m/2, E* = E / (2 (1 - nu^2))."""
    mass = density * 4.0 / 3.0 * math.pi * radius ** 3
    return HertzPair(youngs / (2.0 * (1.0 - poisson ** 2)), radius / 2.0, mass / 2.0,
                     restitution)


def max_overlap(pair: HertzPair, speed: float) -> float:
    """Largest overlap of an elastic impact at relative speed ``speed`` [m/s] -> [m]."""
    return float((15.0 * pair.m_star * speed ** 2
                  / (16.0 * pair.e_star * math.sqrt(pair.r_star))) ** 0.4)


def contact_time(pair: HertzPair, speed: float) -> float:
    """Analytic Hertz contact duration of an elastic impact [s]."""
    return HERTZ_TIME_FACTOR * max_overlap(pair, speed) / speed


def normal_force(pair: HertzPair, overlap: float, overlap_rate: float) -> float:
    """Hertz spring plus dashpot normal force [N] at overlap [m] and its rate [m/s]."""
    if overlap <= 0.0:
        return 0.0
    root = math.sqrt(pair.r_star * overlap)
    sn = 2.0 * pair.e_star * root
    damp = 2.0 * math.sqrt(5.0 / 6.0) * pair.beta * math.sqrt(sn * pair.m_star)
    return 4.0 / 3.0 * pair.e_star * root * overlap + damp * overlap_rate


def damped_impact(pair: HertzPair, speed: float) -> tuple[float, float]:
    """Integrate m* d'' = -F_n(d, d') from d = 0, d' = speed until d returns to 0.

    Returns:
        (contact duration [s], restitution = rebound speed / impact speed [-]).
    """
    from scipy.integrate import solve_ivp

    def rhs(_t: float, y: list[float]) -> list[float]:
        return [y[1], -normal_force(pair, max(y[0], 0.0), y[1]) / pair.m_star]

    def separated(_t: float, y: list[float]) -> float:
        return y[0]

    separated.terminal = True  # type: ignore[attr-defined]
    separated.direction = -1  # type: ignore[attr-defined]
    t_end = 20.0 * contact_time(pair, speed)
    sol = solve_ivp(rhs, (0.0, t_end), [0.0, speed], events=separated, rtol=1e-10,
                    atol=1e-18 + 1e-12 * max_overlap(pair, speed), method='DOP853')
    if not sol.t_events[0].size:
        return math.inf, 0.0
    # The start (d = 0, d' > 0) is no downward crossing, so the first event is the end.
    return float(sol.t_events[0][0]), float(-sol.y_events[0][0][1] / speed)
