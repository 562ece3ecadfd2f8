"""Tool kinematics: accelerate, travel at a steady speed, decelerate (the paper's soil channel).

A :class:`SpeedProfile` is data: steady speed, acceleration, deceleration and the steady
distance. The phase distances and durations follow from the constant-acceleration formulas

    d_acc = v^2 / (2 a),  t_acc = v / a,  t_steady = d_steady / v,  d_dec = v^2 / (2 b)

and the travelled distance s(t) is piecewise quadratic / linear / quadratic (Kuře & Kuřetová,
Technologies 2025, 13, 570, Sec. 2.3). The tool moves along +Z (world frame of the paper:
X lateral, Y up, Z direction of travel).

Assumptions: the tool starts and ends at rest; accelerations are constant within a phase (the
carriage's jerk is not modelled).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True)
class SpeedProfile:
    """Trapezoidal speed profile along +Z.

    Attributes:
        speed_m_s: Steady travel speed v [m/s].
        acceleration_m_s2: Acceleration a of the first phase [m/s^2].
        deceleration_m_s2: Magnitude b of the deceleration of the last phase [m/s^2].
        steady_distance_m: Distance travelled at the steady speed [m].
        name: Label of the profile (e.g. ``paper_1ms``).
    """

    speed_m_s: float
    acceleration_m_s2: float
    deceleration_m_s2: float
    steady_distance_m: float
    name: str = ''

    def __post_init__(self) -> None:
        for field in ('speed_m_s', 'acceleration_m_s2', 'deceleration_m_s2'):
            value = getattr(self, field)
            if not (math.isfinite(value) and value > 0.0):
                msg = f'SpeedProfile.{field}: must be a positive number, got {value!r}'
                raise ValueError(msg)
        if not (math.isfinite(self.steady_distance_m) and self.steady_distance_m >= 0.0):
            msg = f'SpeedProfile.steady_distance_m: must be >= 0, got {self.steady_distance_m!r}'
            raise ValueError(msg)

    @classmethod
    def from_distances(cls, speed_m_s: float, acceleration_distance_m: float,
                       steady_distance_m: float, deceleration_distance_m: float,
                       name: str = '') -> SpeedProfile:
        """Build a profile from its phase distances, a = v^2 / (2 d) [m/s^2]."""
        if acceleration_distance_m <= 0.0 or deceleration_distance_m <= 0.0:
            msg = (f'SpeedProfile: phase distances must be positive, got '
                   f'{acceleration_distance_m!r} and {deceleration_distance_m!r}')
            raise ValueError(msg)
        return cls(speed_m_s, speed_m_s**2 / (2.0 * acceleration_distance_m),
                   speed_m_s**2 / (2.0 * deceleration_distance_m), steady_distance_m, name)

    @property
    def acceleration_distance_m(self) -> float:
        """Distance of the acceleration phase v^2 / (2 a) [m]."""
        return self.speed_m_s**2 / (2.0 * self.acceleration_m_s2)

    @property
    def deceleration_distance_m(self) -> float:
        """Distance of the deceleration phase v^2 / (2 b) [m]."""
        return self.speed_m_s**2 / (2.0 * self.deceleration_m_s2)

    @property
    def acceleration_time_s(self) -> float:
        """Duration of the acceleration phase v / a [s]."""
        return self.speed_m_s / self.acceleration_m_s2

    @property
    def steady_time_s(self) -> float:
        """Duration of the steady phase d / v [s]."""
        return self.steady_distance_m / self.speed_m_s

    @property
    def deceleration_time_s(self) -> float:
        """Duration of the deceleration phase v / b [s]."""
        return self.speed_m_s / self.deceleration_m_s2

    @property
    def total_time_s(self) -> float:
        """Duration of the whole pass [s]."""
        return self.acceleration_time_s + self.steady_time_s + self.deceleration_time_s

    @property
    def total_distance_m(self) -> float:
        """Length of the whole pass [m]."""
        return (self.acceleration_distance_m + self.steady_distance_m
                + self.deceleration_distance_m)

    def scaled(self, factor: float) -> SpeedProfile:
        """The same distances driven ``factor`` times faster (speeds x f, accelerations x f^2)."""
        if not (math.isfinite(factor) and factor > 0.0):
            msg = f'SpeedProfile.scaled: factor must be positive, got {factor!r}'
            raise ValueError(msg)
        return replace(self, speed_m_s=self.speed_m_s * factor,
                       acceleration_m_s2=self.acceleration_m_s2 * factor**2,
                       deceleration_m_s2=self.deceleration_m_s2 * factor**2)

    def velocity(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """Speed along +Z at times ``t_s`` [s] -> [m/s] (same shape; 0 outside the pass)."""
        t = np.asarray(t_s, dtype=np.float64)
        t1 = self.acceleration_time_s
        t2 = t1 + self.steady_time_s
        t3 = t2 + self.deceleration_time_s
        v = self.speed_m_s
        out = np.where(t < t1, self.acceleration_m_s2 * t,
                       np.where(t < t2, v, v - self.deceleration_m_s2 * (t - t2)))
        return np.where((t <= 0.0) | (t >= t3), 0.0, out)

    def distance(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """Travelled distance s(t) at times ``t_s`` [s] -> [m] (same shape, clamped)."""
        t = np.clip(np.asarray(t_s, dtype=np.float64), 0.0, self.total_time_s)
        t1 = self.acceleration_time_s
        t2 = t1 + self.steady_time_s
        v, a, b = self.speed_m_s, self.acceleration_m_s2, self.deceleration_m_s2
        d1 = self.acceleration_distance_m
        d2 = d1 + self.steady_distance_m
        tau = t - t2
        return np.where(t < t1, 0.5 * a * t**2,
                        np.where(t < t2, d1 + v * (t - t1), d2 + v * tau - 0.5 * b * tau**2))

    def time_at_distance(self, s_m: float) -> float:
        """Time [s] at which the travelled distance first reaches ``s_m`` [m]."""
        if not 0.0 <= s_m <= self.total_distance_m + 1e-12:
            msg = f'SpeedProfile: distance {s_m!r} m outside 0..{self.total_distance_m:.6g} m'
            raise ValueError(msg)
        d1 = self.acceleration_distance_m
        d2 = d1 + self.steady_distance_m
        if s_m <= d1:
            return math.sqrt(2.0 * s_m / self.acceleration_m_s2)
        if s_m <= d2:
            return self.acceleration_time_s + (s_m - d1) / self.speed_m_s
        rest = min(s_m - d2, self.deceleration_distance_m)
        disc = max(self.speed_m_s**2 - 2.0 * self.deceleration_m_s2 * rest, 0.0)
        t_dec = (self.speed_m_s - math.sqrt(disc)) / self.deceleration_m_s2
        return self.acceleration_time_s + self.steady_time_s + t_dec


@dataclass(frozen=True)
class ToolPath:
    """The tool's reference point driven along +Z by a profile, starting part-way into it.

    Attributes:
        profile: The speed profile.
        start_position_m: Tool reference point at simulation time 0, (3,) [m].
        offset_m: Profile distance already travelled at simulation time 0 [m] (0: at rest).
    """

    profile: SpeedProfile
    start_position_m: tuple[float, float, float]
    offset_m: float = 0.0

    @property
    def start_time_s(self) -> float:
        """Profile time that corresponds to simulation time 0 [s]."""
        return self.profile.time_at_distance(self.offset_m)

    def pose_at(self, t_s: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Position (3,) [m] and velocity (3,) [m/s] of the reference point at sim time ``t_s``."""
        tp = self.start_time_s + t_s
        position = np.array(self.start_position_m, dtype=np.float64)
        position[2] += float(self.profile.distance(tp)) - self.offset_m
        velocity = np.array([0.0, 0.0, float(self.profile.velocity(tp))])
        return position, velocity

    def time_to_travel(self, travel_m: float) -> float:
        """Sim time [s] at which the tool has moved ``travel_m`` [m] from its start position."""
        return self.profile.time_at_distance(self.offset_m + travel_m) - self.start_time_s


# Profile 1 and 2 of the paper (Sec. 2.3): 1.0 m/s reached at 0.5 m/s^2 (1000 mm, 2 s), steady
# 3000 mm; 1.5 m/s reached at 1.1 m/s^2 (1023 mm, 1.36 s), steady 2954.55 mm; 5000 mm in total.
PAPER_1MS = SpeedProfile(1.0, 0.5, 0.5, 3.0, 'paper_1ms')
PAPER_1_5MS = SpeedProfile(1.5, 1.1, 1.1, 2.95455, 'paper_1_5ms')
# Short-bin profiles: the same steady speeds reached over 100 mm, for reduced scenes.
SHORT_1MS = SpeedProfile.from_distances(1.0, 0.1, 0.6, 0.1, 'short_1ms')
SHORT_1_5MS = SpeedProfile.from_distances(1.5, 0.1, 0.6, 0.1, 'short_1_5ms')

PRESETS: Mapping[str, SpeedProfile] = {
    p.name: p for p in (PAPER_1MS, PAPER_1_5MS, SHORT_1MS, SHORT_1_5MS)
}
