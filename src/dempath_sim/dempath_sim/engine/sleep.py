# mypy: disable-error-code="no-untyped-def"
"""Sleeping far field: grains at rest stop being integrated and their mutual pair work stops.

Most of a tillage bin rests during most of a pass. Rigid-body engines put resting bodies to
sleep and wake them on contact; DEM codes offer a frozen region by hand (LIGGGHTS ``fix
freeze``). Here a grain falls asleep by itself and wakes by itself:

* **Falling asleep.** An awake grain is *quiet* at a step when its speed |v| is below
  ``speed_fraction`` x |g| dt (the speed gravity alone gives it in one step), its rim speed
  r |omega| below ``spin_fraction`` x |g| dt (EPSD2's rolling spring has no dashpot, so grains
  of a bed at rest keep a small spin oscillation that moves no contact point far), its force
  imbalance |F_contacts + m g| is below ``force_fraction`` x m |g| (a fraction
  of its weight) and its torque below ``force_fraction`` x m |g| r. A grain quiet for
  ``quiet_steps`` steps in a row falls asleep: its velocity and spin are set to zero (they were
  below the speed bound) and it is no longer integrated.
* **Asleep.** A pair of two sleeping grains is not evaluated: the grains do not move and have no
  speed, so its force would be the same at every step (Hertz spring at a fixed overlap, no
  dashpot, springs not advanced); its springs are kept as they are. A pair with one awake grain
  is evaluated as usual (the sleeping grain enters with zero velocity), and so is every pair of
  a sleeping grain on the *rim* (one that touched an awake grain at the previous step), so that
  the rim grains' contact forces are complete.
* **Waking.** A sleeping grain wakes when (a) an awake grain touching it moves faster than
  ``wake_speed_fraction`` x |g| dt (its centre: the spin oscillation of the grains on the floor
  moves no centre and would keep waking their neighbours), (b) it is on the rim and its own force
  imbalance exceeds ``wake_force_fraction`` x m |g| (its force is complete there), or (c) it
  lies within ``tool_reach_radii`` of the largest radius of the tool's box (the tool never
  touches a sleeping grain). A woken grain starts from rest at the next step (its stored force
  is set to -m g, so the first half-kick leaves it at rest; its forces are evaluated in full
  from then on). Walls do not move, so a sleeping grain's wall contacts cannot change; a rim
  grain's wall contacts are evaluated with its pairs.

With sleeping on and no grain asleep the engine computes exactly what it computes with sleeping
off (same operations in the same order). What sleeping changes: a grain at rest stays exactly at
rest instead of creeping by less than the speed bound per step, and a disturbance reaches a
sleeping grain one step later than it would (its neighbour must first exceed the wake speed).
Whether that changes a run's statistics is measured, not assumed (docs/dem.md, "Sleeping far
field").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from numba import njit, prange


@dataclass(frozen=True)
class SleepSettings:
    """Thresholds of the sleeping far field (module docstring); all fractions are of |g| dt or
    of the grain's weight m |g|.

    Attributes:
        speed_fraction: Quiet below this x |g| dt in speed [-].
        spin_fraction: Quiet below this x |g| dt in rim speed r |omega| [-].
        force_fraction: Quiet below this x m |g| in force imbalance (and x m |g| r in torque) [-].
        quiet_steps: Consecutive quiet steps before a grain falls asleep.
        wake_speed_fraction: A touching awake grain faster than this x |g| dt wakes it [-].
        wake_force_fraction: A rim grain whose force imbalance exceeds this x m |g| wakes [-].
        tool_reach_radii: Grains within this many largest radii of the tool's box wake [-].
    """

    speed_fraction: float = 0.5
    spin_fraction: float = 10.0
    force_fraction: float = 0.1
    quiet_steps: int = 200
    wake_speed_fraction: float = 10.0
    wake_force_fraction: float = 1.0
    tool_reach_radii: float = 4.0

    def __post_init__(self) -> None:
        """Check the ranges; raise ValueError naming the field."""
        for name in ('speed_fraction', 'spin_fraction', 'force_fraction', 'wake_speed_fraction',
                     'wake_force_fraction', 'tool_reach_radii'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                msg = f'SleepSettings.{name} must be a finite number > 0, got {value!r}'
                raise ValueError(msg)
        if self.wake_speed_fraction < self.speed_fraction:
            msg = 'SleepSettings.wake_speed_fraction must be >= speed_fraction'
            raise ValueError(msg)
        if self.wake_force_fraction < self.force_fraction:
            msg = 'SleepSettings.wake_force_fraction must be >= force_fraction'
            raise ValueError(msg)
        if int(self.quiet_steps) != self.quiet_steps or self.quiet_steps < 1:
            msg = f'SleepSettings.quiet_steps must be an integer >= 1, got {self.quiet_steps!r}'
            raise ValueError(msg)


    def scaled(self, factor: float) -> SleepSettings:
        """These settings with every speed and force bound times ``factor`` (quiet steps and the
        tool's reach kept): looser (> 1) for beds that ring at a few g dt after their settle."""
        return SleepSettings(self.speed_fraction * factor, self.spin_fraction * factor,
                             self.force_fraction * factor, self.quiet_steps,
                             self.wake_speed_fraction * factor,
                             self.wake_force_fraction * factor, self.tool_reach_radii)


@njit(parallel=True, cache=True)
def update_sleep(vel, omg, force, torque, mass, rad, gravity, asleep, quiet, rim, touch, wake,
                 near_tool, v_sleep, w_sleep, f_sleep, f_wake, quiet_steps,
                 counts):  # pragma: no cover
    """Put quiet grains to sleep and wake the disturbed ones, after a whole step.

    Args:
        vel, omg: (n, 3) velocities [m/s] and spins [rad/s] (zeroed for grains falling asleep).
        force, torque: (n, 3) contact forces [N] and torques [N m] of this step (set to -m g and
            0 for grains woken, so that the next half-kick leaves them at rest).
        mass, rad: (n,) masses [kg] and radii [m]; gravity: (3,) [m/s^2].
        asleep, quiet, rim: (n,) uint8 state, int32 quiet-step counters, uint8 rim flags
            (updated: rim becomes this step's touch).
        touch, wake: (n,) uint8 flags the pair kernel set this step (cleared here).
        near_tool: (n,) uint8, 1 for grains within the tool's reach (see `near_tool_box`).
        v_sleep, w_sleep: Speed and rim-speed bounds [m/s].
        f_sleep, f_wake: Force fractions of the weight [-].
        quiet_steps: Quiet steps before sleeping.
        counts: (2,) int64 out: grains asleep after the update, grains woken.
    """
    n = vel.shape[0]
    g = math.sqrt(gravity[0] ** 2 + gravity[1] ** 2 + gravity[2] ** 2)
    v2 = v_sleep * v_sleep
    w2 = w_sleep * w_sleep
    n_asleep = 0
    n_woken = 0
    for i in prange(n):
        w = mass[i] * g
        fx = force[i, 0] + mass[i] * gravity[0]
        fy = force[i, 1] + mass[i] * gravity[1]
        fz = force[i, 2] + mass[i] * gravity[2]
        f2 = fx * fx + fy * fy + fz * fz
        if asleep[i]:
            if wake[i] or near_tool[i] or (rim[i] and f2 > (f_wake * w) ** 2):
                asleep[i] = 0
                quiet[i] = 0
                for q in range(3):
                    force[i, q] = -mass[i] * gravity[q]
                    torque[i, q] = 0.0
                n_woken += 1
            else:
                n_asleep += 1
        else:
            s2 = vel[i, 0] ** 2 + vel[i, 1] ** 2 + vel[i, 2] ** 2
            o2 = (omg[i, 0] ** 2 + omg[i, 1] ** 2 + omg[i, 2] ** 2) * rad[i] * rad[i]
            t2 = torque[i, 0] ** 2 + torque[i, 1] ** 2 + torque[i, 2] ** 2
            lim = f_sleep * w
            if (s2 < v2 and o2 < w2 and f2 < lim * lim and t2 < (lim * rad[i]) ** 2
                    and not near_tool[i]):
                quiet[i] += 1
                if quiet[i] >= quiet_steps:
                    asleep[i] = 1
                    for q in range(3):
                        vel[i, q] = 0.0
                        omg[i, q] = 0.0
                    n_asleep += 1
            else:
                quiet[i] = 0
        rim[i] = touch[i]
        touch[i] = 0
        wake[i] = 0
    counts[0] = n_asleep
    counts[1] = n_woken


@njit(parallel=True, cache=True)
def near_tool_box(pos, tool, lo, hi, reach, near):  # pragma: no cover - compiled
    """near[i] = 1 for the grains whose centre lies within ``reach`` [m] of the box [lo, hi]
    (tool frame of the packed pose ``tool``, see `boundary.boundary_forces`), 0 elsewhere.

    A sleeping grain there wakes and an awake one is kept from falling asleep.
    """
    for i in prange(pos.shape[0]):
        rx = pos[i, 0] - tool[0]
        ry = pos[i, 1] - tool[1]
        rz = pos[i, 2] - tool[2]
        px = tool[9] * rx + tool[12] * ry + tool[15] * rz
        py = tool[10] * rx + tool[13] * ry + tool[16] * rz
        pz = tool[11] * rx + tool[14] * ry + tool[17] * rz
        near[i] = 1 if (lo[0] - reach <= px <= hi[0] + reach and lo[1] - reach <= py
                        <= hi[1] + reach and lo[2] - reach <= pz <= hi[2] + reach) else 0
