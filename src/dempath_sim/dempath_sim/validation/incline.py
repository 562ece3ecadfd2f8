"""A sphere on an inclined plane: rest, rolling and sliding against the analytic accelerations.

The plane is the floor y = 0 and gravity is tilted by the incline angle theta (downhill +X).
With Coulomb friction mu (static = dynamic here, as LIGGGHTS has one coefficient) and EPSD2
rolling resistance mu_r (|M_r| <= mu_r R F_n; Ai et al. 2011) a rigid sphere (I = 2/5 m R^2):

* stays at rest while tan(theta) <= mu_r (the rolling torque holds the friction couple);
* rolls without slip with a = 5/7 g (sin(theta) - mu_r cos(theta)) while the friction it needs,
  m g (2/7 sin(theta) + 5/7 mu_r cos(theta)), stays below mu m g cos(theta);
* otherwise slides with a = g (sin(theta) - mu cos(theta)).

So the onset angles are atan(mu_r) for rolling and atan(7/2 mu - 5/2 mu_r) for sliding.
The acceleration is fitted to x(t) over the run after a settling transient.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath.dumpio import read_print
from dempath_sim.engine import Interaction, SimParams
from dempath_sim.liggghts import commands as cmd
from dempath_sim.validation import cases

G = 9.81


@dataclass(frozen=True)
class InclineCase(cases.SphereCase):
    """One incline run (the sphere: see `SphereCase`).

    Attributes:
        angle_deg: Incline angle theta [deg].
        friction: Particle-plane Coulomb coefficient mu [-].
        rolling: Particle-plane rolling resistance mu_r [-] (0 = off).
        duration: Simulated time [s].
        fit_from: Start of the fitted window [s] (after the contact settles).
    """

    angle_deg: float
    friction: float = 0.4
    rolling: float = 0.0
    duration: float = 0.3
    fit_from: float = 0.05

    @property
    def gravity(self) -> tuple[float, float, float]:
        """Gravity (3,) [m/s^2] tilted by the angle, downhill along +X."""
        th = math.radians(self.angle_deg)
        return (G * math.sin(th), -G * math.cos(th), 0.0)

    def params(self) -> SimParams:
        """Sand sphere (0, paper Table 6 modulus) on a steel plane (1)."""
        inter = Interaction(0.3, self.friction, self.friction, self.rolling)
        return cases.case_params(self.material(), inter, walls=1, gravity=self.gravity)

    def regime(self) -> str:
        """'rest', 'roll' or 'slide' by the analytic criteria."""
        th = math.radians(self.angle_deg)
        if math.tan(th) <= self.rolling:
            return 'rest'
        need = 2 / 7 * math.sin(th) + 5 / 7 * self.rolling * math.cos(th)
        return 'roll' if need <= self.friction * math.cos(th) else 'slide'

    def analytic_acceleration(self) -> float:
        """Downhill acceleration of the centre [m/s^2]."""
        th = math.radians(self.angle_deg)
        regime = self.regime()
        if regime == 'rest':
            return 0.0
        if regime == 'roll':
            return 5 / 7 * G * (math.sin(th) - self.rolling * math.cos(th))
        return G * (math.sin(th) - self.friction * math.cos(th))


@dataclass(frozen=True)
class InclineResult:
    """Fitted acceleration [m/s^2] of one engine, with the case."""

    engine: str
    case: InclineCase
    acceleration: float

    @property
    def error(self) -> float:
        """|measured - analytic| / g [-] (absolute, so the rest case is measured too)."""
        return abs(self.acceleration - self.case.analytic_acceleration()) / G


def fit_acceleration(case: InclineCase, t: NDArray[np.float64], x: NDArray[np.float64]) -> float:
    """Second derivative of a quadratic fitted to x(t) for t >= fit_from [m/s^2]."""
    keep = t >= case.fit_from
    return float(2.0 * np.polyfit(t[keep], x[keep], 2)[0])


def incline_dempath(case: InclineCase) -> InclineResult:
    """Run the case on the dempath engine."""
    engine, state = cases.dempath_run(case.params(), np.array([[0.0, case.radius, 0.0]]),
                                      np.array([case.radius]), [cases.FLOOR])
    rows: list[tuple[float, float]] = []
    engine.run(state, 1, callback=lambda st, _e: rows.append((st.time, st.positions[0, 0])))
    steps = int(case.duration / float(engine.dt or 1.0))
    engine.run(state, steps, callback=lambda st, _e: rows.append((st.time, st.positions[0, 0])),
               callback_every=10)
    data = np.array(rows)
    return InclineResult('dempath', case, fit_acceleration(case, data[:, 0], data[:, 1]))


def incline_liggghts(case: InclineCase, workdir: Path, dt: float) -> InclineResult:
    """Run the case on LIGGGHTS with time step ``dt`` [s]."""
    params = case.params()
    r = case.radius
    lines = cases.liggghts_preamble(params, (-0.5, -4 * r, -4 * r), (2.0, 4 * r, 4 * r),
                                    0.5 * r, dt)
    lines += [cmd.plane_wall('floor', params, 'y', 0.0, 1),
              f'create_atoms 1 single 0 {cmd.fmt(r)} 0 units box',
              f'set group all diameter {cmd.fmt(2 * r)} density {cmd.fmt(case.density)}',
              'fix integr all nve/sphere', 'variable t equal step*dt', 'variable x equal x[1]',
              'fix out all print 10 "${t} ${x}" file incline.txt screen no',
              f'run {int(case.duration / dt)}']
    cases.run_liggghts(workdir, 'incline', lines)
    data = read_print(workdir / 'incline.txt', 2)
    return InclineResult('liggghts', case, fit_acceleration(case, data[:, 0], data[:, 1]))
