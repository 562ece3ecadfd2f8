"""Physics validation on both engines: Hertz impact, incline onset, energy conservation."""

from __future__ import annotations

from pathlib import Path

import pytest

from dempath_sim.liggghts.install import LiggghtsInstall
from dempath_sim.validation.energy_conservation import EnergyCase, energy_dempath, energy_liggghts
from dempath_sim.validation.hertz import contact_time, damped_impact, sphere_pair
from dempath_sim.validation.impact import ImpactCase, impact_dempath, impact_liggghts
from dempath_sim.validation.incline import InclineCase, incline_dempath, incline_liggghts

IMPACTS = [ImpactCase(v, e) for v in (0.1, 1.0, 3.0) for e in (1.0, 0.7, 0.3)]
INCLINES = [InclineCase(10.0, rolling=0.26), InclineCase(20.0, rolling=0.26),
            InclineCase(20.0), InclineCase(40.0, rolling=0.26), InclineCase(60.0)]


def test_ode_reference_reproduces_the_analytic_hertz_time() -> None:
    """For e = 1 the integrated contact lasts the analytic 2.9432 d_max / v and rebounds fully."""
    pair = sphere_pair(0.002, 1734.0, 1.7e6, 0.25, 1.0)
    duration, rebound = damped_impact(pair, 1.0)
    assert duration == pytest.approx(contact_time(pair, 1.0), rel=1e-4)
    assert rebound == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize('case', IMPACTS, ids=lambda c: f'v{c.speed}-e{c.restitution}')
def test_dempath_impact_matches_hertz(case: ImpactCase) -> None:
    """dempath: contact duration within 2 % of Hertz and restitution within 2 % of e."""
    result = impact_dempath(case)
    assert result.duration_error < 0.02, result
    assert result.restitution_error < 0.02, result


@pytest.mark.liggghts
@pytest.mark.parametrize('case', IMPACTS[::2], ids=lambda c: f'v{c.speed}-e{c.restitution}')
def test_liggghts_impact_matches_hertz(liggghts: LiggghtsInstall, case: ImpactCase,
                                       tmp_path: Path) -> None:
    """LIGGGHTS: the same impact within the same 2 % bars."""
    result = impact_liggghts(case, tmp_path)
    assert result.duration_error < 0.02, result
    assert result.restitution_error < 0.02, result


@pytest.mark.parametrize('case', INCLINES, ids=lambda c: f'{c.angle_deg}deg-mur{c.rolling}')
def test_dempath_incline_regimes(case: InclineCase) -> None:
    """dempath: rest below atan(mu_r), rolling and sliding accelerations within 1 % of g."""
    assert incline_dempath(case).error < 0.01


@pytest.mark.liggghts
@pytest.mark.parametrize('case', INCLINES[:3], ids=lambda c: f'{c.angle_deg}deg-mur{c.rolling}')
def test_liggghts_incline_regimes(liggghts: LiggghtsInstall, case: InclineCase,
                                  tmp_path: Path) -> None:
    """LIGGGHTS: the same regimes and accelerations within 1 % of g."""
    assert incline_liggghts(case, tmp_path, 8.5e-5).error < 0.01


def test_dempath_energy_drift_below_one_percent() -> None:
    """dempath: elastic frictionless box, kinetic + Hertz energy drifts < 1 % in 10,000 steps."""
    assert energy_dempath(EnergyCase()).drift < 0.01


@pytest.mark.liggghts
def test_liggghts_energy_drift_below_one_percent(liggghts: LiggghtsInstall,
                                                 tmp_path: Path) -> None:
    """LIGGGHTS: the same box and bar, at dempath's time step."""
    case = EnergyCase()
    assert energy_liggghts(case, tmp_path, 8.55e-5).drift < 0.01
