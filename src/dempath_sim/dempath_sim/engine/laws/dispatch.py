# mypy: disable-error-code="no-untyped-def"
"""One contact, all laws: Hertz-Mindlin, optional EPSD2 rolling resistance and SJKR cohesion.

The pair table `tab` (n_mat, n_mat, N_TAB) float64 holds, per material pair, the coefficients the
laws need (columns below); `build_pair_table` fills it from `SimParams`. `resolve_contact` is the
scalar per-contact function shared by the particle-particle, particle-plane and
particle-triangle kernels, so every geometry uses the same laws and per-pair materials.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from dempath_sim.engine.laws.hertz_mindlin import hertz_mindlin, hertz_mindlin_constants
from dempath_sim.engine.laws.rolling_epsd2 import rolling_epsd2
from dempath_sim.engine.materials import pair_properties
from dempath_sim.engine.params import SimParams

# Columns of the pair table; the last four are the law's constants, precomputed once per pair
# (see `hertz_mindlin.py`): 4/3 E*, 8 G*, 2 sqrt(5/6) beta sqrt(2 E*) and
# 2 sqrt(5/6) beta sqrt(8 G*), so that a contact takes one sqrt for both dashpots.
# TAB_SPRING is 1 where the Coulomb limit bounds the tangential spring alone
# (``SimParams.coulomb_limit == 'spring'``, LIGGGHTS 3.8) and 0 where it bounds spring + dashpot;
# TAB_FORMS is 1 for LIGGGHTS 3.8's spring and lever-arm forms (``SimParams.contact_forms``).
(TAB_E, TAB_G, TAB_BETA, TAB_MUS, TAB_MUD, TAB_MUR, TAB_KC, TAB_OK,
 TAB_KN, TAB_KT, TAB_CN, TAB_CT, TAB_SPRING, TAB_FORMS) = range(14)
N_TAB = 14


def build_pair_table(params: SimParams) -> NDArray[np.float64]:
    """Pair coefficient table (n_mat, n_mat, N_TAB); TAB_OK is 0 where no interaction is given."""
    n = len(params.materials)
    tab = np.zeros((n, n, N_TAB))
    for i in range(n):
        for j in range(n):
            if not params.has_interaction(i, j):
                continue
            props = pair_properties(params.materials[i], params.materials[j])
            inter = params.interaction(i, j)
            e_star, g_star = props.effective_youngs, props.effective_shear
            beta = inter.damping_beta
            tab[i, j] = (e_star, g_star, beta, inter.static_friction, inter.dynamic_friction,
                         inter.rolling_resistance, inter.cohesion_energy_density, 1.0,
                         *hertz_mindlin_constants(e_star, g_star, beta),
                         1.0 if params.coulomb_limit == 'spring' else 0.0,
                         1.0 if params.contact_forms == 'liggghts' else 0.0)
    return tab


@njit(inline='always', fastmath=True, cache=True)
def resolve_contact(tab, a, b, delta, r_eff, m_eff, area, nx, ny, nz, vx, vy, vz, wx, wy, wz,
                    ht, hr, k, dt, rolling):  # pragma: no cover - compiled
    """Total contact force and rolling torque on body i for one contact.

    Args:
        tab: (n_mat, n_mat, N_TAB) pair table.
        a, b: Material indices of i and j.
        delta: Overlap > 0 [m].
        r_eff, m_eff: Effective radius [m] and mass [kg].
        area: Contact-circle area for SJKR [m^2].
        nx, ny, nz: Unit normal from j to i.
        vx, vy, vz: Relative contact-point velocity of i w.r.t. j [m/s].
        wx, wy, wz: Relative angular velocity omega_i - omega_j [rad/s].
        ht, hr: (m, 3) tangential [m] and rolling [N m] spring histories; row k is this contact.
        k: History row.
        dt: Time step [s].
        rolling: Whether rolling resistance is on.

    Returns:
        (fx, fy, fz, mx, my, mz, f_n): force on i [N], rolling torque on i [N m], normal force
        magnitude before cohesion [N].
    """
    f_n, ftx, fty, ftz, k_t = hertz_mindlin(
        delta, r_eff, m_eff, tab[a, b, TAB_KN], tab[a, b, TAB_KT], tab[a, b, TAB_CN],
        tab[a, b, TAB_CT], tab[a, b, TAB_MUS], tab[a, b, TAB_MUD], nx, ny, nz, vx, vy, vz, ht, k,
        dt, tab[a, b, TAB_SPRING], tab[a, b, TAB_FORMS])
    f_norm = f_n - tab[a, b, TAB_KC] * area
    mx = 0.0
    my = 0.0
    mz = 0.0
    if rolling and tab[a, b, TAB_MUR] > 0.0:
        mx, my, mz = rolling_epsd2(r_eff, k_t, f_n, tab[a, b, TAB_MUR], nx, ny, nz,
                                   wx, wy, wz, hr, k, dt, tab[a, b, TAB_FORMS])
    return (f_norm * nx + ftx, f_norm * ny + fty, f_norm * nz + ftz, mx, my, mz, f_n)
