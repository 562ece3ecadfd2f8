# mypy: disable-error-code="no-untyped-def"
"""Rolling resistance of type C (elastic-plastic spring-dashpot, EPSD2 without dashpot).

A rolling spring torque M_r on body i, kept as contact history (Ai et al., Powder Technol. 206
(2011) 269, model C; LIGGGHTS `rolling_friction epsd2`)::

    M_r <- M_r projected on the tangent plane (length kept) - k_r omega_r dt,
    k_r = k_t R*^2,     |M_r| <= mu_r R* max(F_n, 0)  (full mobilisation: the spring slips),

where omega_r = (omega_i - omega_j) minus its component along n (twisting is not resisted) and
k_t the Mindlin tangential stiffness of the contact. Body j receives -M_r.
"""

from __future__ import annotations

import math

from numba import njit


@njit(inline='always', fastmath=True, cache=True)
def rolling_epsd2(r_eff, k_t, f_n, mu_r, nx, ny, nz, wx, wy, wz,
                  hist, k, dt, forms=0.0):  # pragma: no cover - compiled
    """Rolling resistance torque of one contact; updates the rolling spring in place.

    Args:
        r_eff: Effective rolling radius R* [m].
        k_t: Tangential stiffness of the contact [N/m].
        f_n: Normal force magnitude [N].
        mu_r: Rolling resistance coefficient [-].
        nx, ny, nz: Unit normal from j to i.
        wx, wy, wz: Relative angular velocity omega_i - omega_j [rad/s].
        hist: (m, 3) rolling springs [N m]; row k belongs to this contact.
        k: Row of this contact.
        dt: Time step [s].
        forms: 0: the carried spring is turned into the new tangent plane with its length kept
            and the limit uses max(F_n, 0); 1: LIGGGHTS 3.8's ``epsd2``: the spring is carried
            as it is and the limit uses |F_n|.

    Returns:
        (mx, my, mz): rolling torque on i [N m].
    """
    wn = wx * nx + wy * ny + wz * nz
    k_r = k_t * r_eff * r_eff
    mx = hist[k, 0]
    my = hist[k, 1]
    mz = hist[k, 2]
    old2 = mx * mx + my * my + mz * mz
    if old2 > 0.0 and forms == 0.0:
        mdn = mx * nx + my * ny + mz * nz
        mx -= mdn * nx
        my -= mdn * ny
        mz -= mdn * nz
        new2 = mx * mx + my * my + mz * mz
        if new2 > 0.0:
            scale = math.sqrt(old2 / new2)
            mx *= scale
            my *= scale
            mz *= scale
    mx -= k_r * (wx - wn * nx) * dt
    my -= k_r * (wy - wn * ny) * dt
    mz -= k_r * (wz - wn * nz) * dt
    limit = mu_r * r_eff * (abs(f_n) if forms > 0.0 else max(f_n, 0.0))
    m2 = mx * mx + my * my + mz * mz
    if m2 > limit * limit:
        scale = limit / math.sqrt(m2) if m2 > 0.0 else 0.0
        mx *= scale
        my *= scale
        mz *= scale
    hist[k, 0] = mx
    hist[k, 1] = my
    hist[k, 2] = mz
    return mx, my, mz
