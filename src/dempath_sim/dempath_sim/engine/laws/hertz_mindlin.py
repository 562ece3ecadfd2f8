# mypy: disable-error-code="no-untyped-def"
"""Hertz-Mindlin contact law: Hertzian normal spring-dashpot and Mindlin tangential spring.

Normal force on body i (along the unit normal n pointing from j to i), overlap delta > 0::

    F_n = k_n delta - gamma_n v_n,        k_n = 4/3 E* sqrt(R* delta),
    gamma_n = 2 sqrt(5/6) beta sqrt(S_n m*),   S_n = 2 E* sqrt(R* delta),
    beta = -ln e / sqrt(ln^2 e + pi^2),

with v_n = (v_i - v_j) . n at the contact point (negative while approaching). This damping gives a
velocity-independent restitution equal to e (Tsuji et al., Powder Technol. 71 (1992) 239;
Antypov & Elliott, EPL 94 (2011) 50004); it is the form of LIGGGHTS `model hertz`. F_n may turn
slightly tensile just before separation, as in LIGGGHTS (needed for the exact restitution).

Tangential force (Mindlin & Deresiewicz 1953, no-slip stiffness, incremental history)::

    xi <- xi projected on the tangent plane (length kept) + v_t dt,
    F_t = -k_t xi - gamma_t v_t,  k_t = 8 G* sqrt(R* delta),
    gamma_t = 2 sqrt(5/6) beta sqrt(k_t m*),

with Coulomb's limit: sticking while |F_t| <= mu_s max(F_n, 0); otherwise sliding with
|F_t| = mu_d max(F_n, 0) and the spring reset to match (LIGGGHTS `tangential history` with separate
static and dynamic coefficients, as in Rocky). All functions are scalar per-contact code so that
the same source runs in numba CPU loops and could run in CUDA kernels.

The kernel takes the per-pair constants c_n = 4/3 E*, c_t = 8 G*, d_n = 2 sqrt(5/6) beta
sqrt(2 E*) and d_t = 2 sqrt(5/6) beta sqrt(8 G*) (`hertz_mindlin_constants`, stored in the pair
table), so that with s = sqrt(R* delta) and w = sqrt(s m*) a contact costs two square roots:
k_n = c_n s, k_t = c_t s, gamma_n = d_n w, gamma_t = d_t w (the same law, regrouped).
"""

from __future__ import annotations

import math

from numba import njit

SQRT_5_6 = math.sqrt(5.0 / 6.0)  # damping prefactor of the Tsuji/Antypov dashpot


def hertz_mindlin_constants(e_star: float, g_star: float,
                            beta: float) -> tuple[float, float, float, float]:
    """Per-pair constants of the law (see the module docstring).

    Args:
        e_star: Effective Young's modulus E* [Pa].
        g_star: Effective shear modulus G* [Pa].
        beta: Damping ratio from the restitution [-].

    Returns:
        (c_n [Pa], c_t [Pa], d_n [Pa^0.5], d_t [Pa^0.5]): 4/3 E*, 8 G*,
        2 sqrt(5/6) beta sqrt(2 E*), 2 sqrt(5/6) beta sqrt(8 G*).
    """
    return ((4.0 / 3.0) * e_star, 8.0 * g_star, 2.0 * SQRT_5_6 * beta * math.sqrt(2.0 * e_star),
            2.0 * SQRT_5_6 * beta * math.sqrt(8.0 * g_star))


@njit(inline='always', fastmath=True, cache=True)
def hertz_mindlin(delta, r_eff, m_eff, c_n, c_t, d_n, d_t, mu_s, mu_d,
                  nx, ny, nz, vx, vy, vz, hist, k, dt, spring_limit=0.0,
                  forms=0.0):  # pragma: no cover
    """Normal and tangential force of one contact; updates the tangential spring in place.

    Args:
        delta: Overlap > 0 [m].
        r_eff: Effective radius R* [m].
        m_eff: Effective mass m* [kg].
        c_n, c_t: 4/3 E* and 8 G* [Pa] (see `hertz_mindlin_constants`).
        d_n, d_t: 2 sqrt(5/6) beta sqrt(2 E*) and 2 sqrt(5/6) beta sqrt(8 G*) [Pa^0.5].
        mu_s: Static friction coefficient [-].
        mu_d: Dynamic friction coefficient [-].
        nx, ny, nz: Unit normal from j to i.
        vx, vy, vz: Relative velocity of i with respect to j at the contact point [m/s].
        hist: (m, 3) tangential springs [m]; row k belongs to this contact.
        k: Row of this contact in hist.
        dt: Time step [s].
        spring_limit: 0: the Coulomb limit bounds the whole tangential force (spring and
            dashpot) by mu_s max(F_n, 0); 1: it bounds the spring alone by mu_s |F_n| and the
            dashpot is dropped while sliding (LIGGGHTS 3.8 ``tangential history``).
        forms: 0: the carried spring is turned into the new tangent plane with its length kept;
            1: its normal part is dropped (LIGGGHTS 3.8: the spring shrinks as the normal turns).

    Returns:
        (f_n, ftx, fty, ftz, k_t): normal force magnitude on i along n [N] (positive repulsive),
        tangential force on i (3,) [N] and the tangential stiffness [N/m].
    """
    sq = math.sqrt(r_eff * delta)
    w = math.sqrt(sq * m_eff)
    k_n = c_n * sq
    gamma_n = d_n * w
    v_n = vx * nx + vy * ny + vz * nz
    f_n = k_n * delta - gamma_n * v_n
    vtx = vx - v_n * nx
    vty = vy - v_n * ny
    vtz = vz - v_n * nz
    k_t = c_t * sq
    gamma_t = d_t * w
    sx = hist[k, 0]
    sy = hist[k, 1]
    sz = hist[k, 2]
    old2 = sx * sx + sy * sy + sz * sz
    if old2 > 0.0:
        sdn = sx * nx + sy * ny + sz * nz
        sx -= sdn * nx
        sy -= sdn * ny
        sz -= sdn * nz
        new2 = sx * sx + sy * sy + sz * sz
        if new2 > 0.0 and forms == 0.0:
            scale = math.sqrt(old2 / new2)
            sx *= scale
            sy *= scale
            sz *= scale
    sx += vtx * dt
    sy += vty * dt
    sz += vtz * dt
    if spring_limit > 0.0:
        return _spring_limited(f_n, k_t, gamma_t, mu_s, mu_d, sx, sy, sz, vtx, vty, vtz,
                               hist, k)
    ftx = -k_t * sx - gamma_t * vtx
    fty = -k_t * sy - gamma_t * vty
    ftz = -k_t * sz - gamma_t * vtz
    f_lim = max(f_n, 0.0)
    ft2 = ftx * ftx + fty * fty + ftz * ftz
    if ft2 > (mu_s * f_lim) ** 2:
        scale = mu_d * f_lim / math.sqrt(ft2)
        ftx *= scale
        fty *= scale
        ftz *= scale
        sx = -(ftx + gamma_t * vtx) / k_t
        sy = -(fty + gamma_t * vty) / k_t
        sz = -(ftz + gamma_t * vtz) / k_t
    hist[k, 0] = sx
    hist[k, 1] = sy
    hist[k, 2] = sz
    return f_n, ftx, fty, ftz, k_t


@njit(inline='always', fastmath=True, cache=True)
def _spring_limited(f_n, k_t, gamma_t, mu_s, mu_d, sx, sy, sz, vtx, vty, vtz,
                    hist, k):  # pragma: no cover - compiled
    """Coulomb limit on the spring alone (LIGGGHTS 3.8 ``tangential history``).

    Sticking while k_t |xi| <= mu_s |F_n|: F_t = -k_t xi - gamma_t v_t (the dashpot may take
    |F_t| above the limit); otherwise F_t = mu_d |F_n| along -xi, no dashpot, and the spring is
    cut back to match. Same return values as ``hertz_mindlin``.
    """
    f_lim = abs(f_n)
    s2 = sx * sx + sy * sy + sz * sz
    fs = k_t * math.sqrt(s2)
    if fs > mu_s * f_lim:
        scale = mu_d * f_lim / fs if fs > 0.0 else 0.0
        sx *= scale
        sy *= scale
        sz *= scale
        ftx = -k_t * sx
        fty = -k_t * sy
        ftz = -k_t * sz
    else:
        ftx = -k_t * sx - gamma_t * vtx
        fty = -k_t * sy - gamma_t * vty
        ftz = -k_t * sz - gamma_t * vtz
    hist[k, 0] = sx
    hist[k, 1] = sy
    hist[k, 2] = sz
    return f_n, ftx, fty, ftz, k_t
