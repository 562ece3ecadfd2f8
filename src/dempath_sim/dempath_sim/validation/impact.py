"""Two-sphere normal impact: contact duration and restitution against Hertz theory.

Two identical spheres approach head-on along X at relative speed v (no gravity, no friction
effect in a central impact). Measured: the contact duration (overlap > 0) and the restitution
(rebound / impact relative speed). References (``hertz`` module): the analytic Hertz duration for
e = 1, the damped-ODE duration for e < 1, and the set restitution e.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine import Engine, Interaction, SimParams, SimState
from dempath_sim.liggghts import commands as cmd
from dempath_sim.validation import cases
from dempath_sim.validation.hertz import HertzPair, contact_time, damped_impact, sphere_pair


@dataclass(frozen=True)
class ImpactCase(cases.SphereCase):
    """One impact: sand-like spheres (paper Table 2 / 6 values by default; see `SphereCase`).

    Attributes:
        speed: Relative approach speed v [m/s].
        restitution: Set coefficient of restitution e [-].
        steps_per_contact: Time steps per analytic contact duration.
    """

    speed: float
    restitution: float
    steps_per_contact: int = 400

    @property
    def pair(self) -> HertzPair:
        """Effective contact quantities of the two spheres."""
        return sphere_pair(self.radius, self.density, self.youngs, self.poisson,
                           self.restitution)

    @property
    def dt(self) -> float:
        """Time step [s]: the analytic duration / steps_per_contact."""
        return contact_time(self.pair, self.speed) / self.steps_per_contact

    def params(self) -> SimParams:
        """One material, one interaction, no gravity."""
        # Soft sand at 1-3 m/s overlaps by up to ~20% of the radius (Hertz: d_max above).
        return cases.case_params(self.material(), Interaction(self.restitution, 0.5, 0.5),
                                 gravity=(0.0, 0.0, 0.0), dt=self.dt, max_overlap_fraction=0.5)


@dataclass(frozen=True)
class ImpactResult:
    """Measured and reference values of one impact.

    Attributes:
        engine: 'dempath' or 'liggghts'.
        case: The impact set-up.
        duration: Measured contact duration [s].
        restitution: Measured restitution [-].
        reference_duration: Analytic (e = 1) or damped-ODE (e < 1) duration [s].
    """

    engine: str
    case: ImpactCase
    duration: float
    restitution: float
    reference_duration: float

    @property
    def duration_error(self) -> float:
        """Relative error of the duration [-]."""
        return abs(self.duration / self.reference_duration - 1.0)

    @property
    def restitution_error(self) -> float:
        """Relative error of the restitution against the set value [-]."""
        return abs(self.restitution / self.case.restitution - 1.0)


def reference_duration(case: ImpactCase) -> float:
    """Analytic Hertz duration for e = 1, damped-ODE duration otherwise [s]."""
    if case.restitution >= 1.0:
        return contact_time(case.pair, case.speed)
    return damped_impact(case.pair, case.speed)[0]


def measure(engine: str, case: ImpactCase, times: NDArray[np.float64], gaps: NDArray[np.float64],
            rel_speed: NDArray[np.float64]) -> ImpactResult:
    """Contact duration and restitution from a sampled run.

    Args:
        engine: Engine name.
        case: The set-up.
        times: (nt,) sample times [s], one per step.
        gaps: (nt,) centre distance minus 2 radii [m] (< 0 in contact).
        rel_speed: (nt,) closing speed v1x - v2x [m/s].
    """
    touching = gaps < 0.0
    idx = np.flatnonzero(touching)
    if idx.size == 0:
        return ImpactResult(engine, case, math.nan, math.nan, reference_duration(case))
    first, last = idx[0], idx[-1]
    # Linear interpolation of the gap's zero crossings on either side of the contact.
    t0 = np.interp(0.0, [gaps[first], gaps[first - 1]], [times[first], times[first - 1]])
    t1 = np.interp(0.0, [gaps[last], gaps[last + 1]], [times[last], times[last + 1]])
    rebound = -float(rel_speed[-1])
    return ImpactResult(engine, case, float(t1 - t0), rebound / case.speed,
                        reference_duration(case))


def _liggghts_deck(case: ImpactCase) -> list[str]:
    params = case.params()
    r, gap0 = case.radius, 0.05 * case.radius
    x0 = r + gap0 / 2.0
    steps = int(3 * case.steps_per_contact + gap0 / case.speed / case.dt) + 50
    lines = cases.liggghts_preamble(params, (-20 * r, -4 * r, -4 * r),
                                    (20 * r, 4 * r, 4 * r), 0.5 * r, case.dt, hard=False)
    lines += [f'create_atoms 1 single {cmd.fmt(-x0)} 0 0 units box',
              f'create_atoms 1 single {cmd.fmt(x0)} 0 0 units box',
              f'set group all diameter {cmd.fmt(2 * r)} density {cmd.fmt(case.density)}',
              f'set atom 1 vx {cmd.fmt(case.speed / 2)}',
              f'set atom 2 vx {cmd.fmt(-case.speed / 2)}',
              'fix integr all nve/sphere',
              'variable t equal step*dt',
              f'variable gap equal x[2]-x[1]-{cmd.fmt(2 * r)}',
              'variable vrel equal vx[1]-vx[2]',
              'fix out all print 1 "${t} ${gap} ${vrel}" file impact.txt screen no',
              'thermo 100000', f'run {steps}']
    return lines


def impact_liggghts(case: ImpactCase, workdir: Path) -> ImpactResult:
    """Run the impact with LIGGGHTS in ``workdir`` and measure it."""
    cases.run_liggghts(workdir, 'impact', _liggghts_deck(case))
    data = np.loadtxt(workdir / 'impact.txt', comments='#', ndmin=2)
    return measure('liggghts', case, data[:, 0], data[:, 1], data[:, 2])


def impact_dempath(case: ImpactCase) -> ImpactResult:
    """Run the impact with the dempath engine and measure it."""
    r, gap0 = case.radius, 0.05 * case.radius
    x0 = r + gap0 / 2.0
    pos = np.array([[-x0, 0.0, 0.0], [x0, 0.0, 0.0]])
    vel = np.array([[case.speed / 2, 0.0, 0.0], [-case.speed / 2, 0.0, 0.0]])
    engine, state = cases.dempath_run(case.params(), pos, np.full(2, r), velocities=vel)
    rows: list[tuple[float, float, float]] = []

    def sample(st: SimState, _eng: Engine) -> None:
        rows.append((st.time, st.positions[1, 0] - st.positions[0, 0] - 2 * r,
                     st.velocities[0, 0] - st.velocities[1, 0]))

    steps = int(3 * case.steps_per_contact + gap0 / case.speed / case.dt) + 50
    engine.run(state, steps, callback=sample)
    data = np.array(rows)
    return measure('dempath', case, data[:, 0], data[:, 1], data[:, 2])
