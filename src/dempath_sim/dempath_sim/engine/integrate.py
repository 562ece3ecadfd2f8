# mypy: disable-error-code="no-untyped-def"
"""Velocity-Verlet integration of translation and rotation (spheres: isotropic inertia).

    v(t + dt/2) = v(t) + dt/2 (F(t)/m + g),     x(t + dt) = x(t) + dt v(t + dt/2),
    [forces at t + dt from x(t + dt) and the half-step velocities]
    v(t + dt) = v(t + dt/2) + dt/2 (F(t + dt)/m + g),

and the same for omega with T / I (Allen & Tildesley, 2nd ed., 3.2.1; LIGGGHTS `fix nve/sphere`).
Symplectic and time-reversible for conservative forces. The first half-kick also reports, per
chunk, the largest displacement since the last neighbour-list build, the largest |v| dt / r (a
blow-up indicator), the number of particles outside the domain box and the number of non-finite
velocities. No fastmath here, so that the NaN checks hold. Sleeping grains (`asleep`, see
`sleep.py`) are neither kicked nor moved.
"""

from __future__ import annotations

import math

from numba import njit, prange


@njit(parallel=True, cache=True)
def first_half(pos, vel, omg, force, torque, mass, inertia, rad, gravity, dt, pos_build,
               dom_lo, dom_hi, stats, asleep):  # pragma: no cover - compiled
    """Half kick and drift; stats (n_chunks, 4) out: max disp^2, max |v|dt/r, n_out, n_nan."""
    n_chunks = stats.shape[0]
    n = pos.shape[0]
    h = 0.5 * dt
    for c in prange(n_chunks):
        disp2 = 0.0
        courant = 0.0
        n_out = 0.0
        n_bad = 0.0
        for i in range(c * n // n_chunks, (c + 1) * n // n_chunks):
            if asleep[i]:
                continue
            inv_m = 1.0 / mass[i]
            inv_i = 1.0 / inertia[i]
            v2 = 0.0
            d2 = 0.0
            out = False
            for q in range(3):
                vel[i, q] += h * (force[i, q] * inv_m + gravity[q])
                omg[i, q] += h * torque[i, q] * inv_i
                pos[i, q] += dt * vel[i, q]
                v2 += vel[i, q] * vel[i, q]
                d2 += (pos[i, q] - pos_build[i, q]) ** 2
                out = out or pos[i, q] < dom_lo[q] or pos[i, q] > dom_hi[q]
            if not (math.isfinite(v2) and math.isfinite(d2)):
                n_bad += 1.0
                continue
            disp2 = max(disp2, d2)
            courant = max(courant, math.sqrt(v2) * dt / rad[i])
            if out:
                n_out += 1.0
        stats[c, 0] = disp2
        stats[c, 1] = courant
        stats[c, 2] = n_out
        stats[c, 3] = n_bad


@njit(parallel=True, cache=True)
def second_half(vel, omg, force, torque, mass, inertia, gravity, dt,
                asleep):  # pragma: no cover
    """Second half kick with the forces at t + dt (sleeping grains: none)."""
    h = 0.5 * dt
    for i in prange(vel.shape[0]):
        if asleep[i]:
            continue
        inv_m = 1.0 / mass[i]
        inv_i = 1.0 / inertia[i]
        for q in range(3):
            vel[i, q] += h * (force[i, q] * inv_m + gravity[q])
            omg[i, q] += h * torque[i, q] * inv_i
