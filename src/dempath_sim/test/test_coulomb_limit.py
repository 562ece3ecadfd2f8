"""The two Coulomb limits of the tangential law: on spring + dashpot (default) or on the spring
alone (LIGGGHTS 3.8); the scene option is tested in test_contact_forms.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dempath_sim.engine.laws.hertz_mindlin import hertz_mindlin, hertz_mindlin_constants

E_STAR, G_STAR, BETA = 1.0e6, 4.0e5, 0.35  # Pa, Pa, - (soft sand, e ~ 0.3)
R_EFF, M_EFF, DT = 2e-3, 3e-5, 1e-5  # m, kg, s
MU_S, MU_D = 0.5, 0.4


def _force(spring: float, spring0: float, vt: float, vn: float = 0.0,
           delta: float = 1e-4) -> tuple[float, float, np.ndarray]:
    """(F_n, |F_t|, new spring) for a contact along +Y with tangential velocity vt along X."""
    hist = np.array([[spring0, 0.0, 0.0]])
    c = hertz_mindlin_constants(E_STAR, G_STAR, BETA)
    f_n, ftx, fty, ftz, _ = hertz_mindlin(delta, R_EFF, M_EFF, *c, MU_S, MU_D, 0.0, 1.0, 0.0,
                                          vt, vn, 0.0, hist, 0, DT, spring)
    return f_n, math.sqrt(ftx * ftx + fty * fty + ftz * ftz), hist[0]


def test_sticking_spring_limit_keeps_the_dashpot_above_mu_fn() -> None:
    """A sticking spring just under mu_s F_n plus a fast slip: only the spring-limited law
    lets the dashpot take |F_t| above mu_s F_n."""
    f_n, _, _ = _force(0.0, 0.0, 0.0)
    k_t = 8 * G_STAR * math.sqrt(R_EFF * 1e-4)
    xi = -0.95 * MU_S * f_n / k_t  # spring force +0.95 mu_s F_n along +X
    _, ft_spring, _ = _force(1.0, xi, -0.05)
    _, ft_total, _ = _force(0.0, xi, -0.05)
    assert ft_spring > MU_S * f_n
    assert ft_total == pytest.approx(MU_D * f_n, rel=1e-9)


def test_sliding_spring_limit_drops_the_dashpot() -> None:
    """A spring far beyond the limit slides at exactly mu_d |F_n| and is cut back to it."""
    f_n, ft, spring = _force(1.0, -1e-3, 0.3)
    k_t = 8 * G_STAR * math.sqrt(R_EFF * 1e-4)
    assert ft == pytest.approx(MU_D * abs(f_n), rel=1e-9)
    assert k_t * abs(spring[0]) == pytest.approx(MU_D * abs(f_n), rel=1e-9)


def test_laws_agree_without_a_dashpot_contribution() -> None:
    """With no tangential velocity both limits give the same force and spring."""
    for xi in (1e-7, -3e-6, 5e-4):
        a = _force(1.0, xi, 0.0)
        b = _force(0.0, xi, 0.0)
        assert a[1] == pytest.approx(b[1], rel=1e-12)
        assert np.allclose(a[2], b[2], rtol=1e-12)

