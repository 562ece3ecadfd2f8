# mypy: disable-error-code="no-untyped-def"
"""Particle-particle contact forces over a half neighbour list, race-free with per-chunk buffers.

The particles are split into `n_chunks` contiguous ranges (one per thread); the pair (i, j) with
j > i is resolved once by the chunk owning i, which adds +F to i and -F to j in its own buffer, so
no two threads write the same memory. `reduce_buffers` sums the buffers. A chunk writes only the
rows from its first particle to its highest neighbour (`chunk_windows`, found at each list build;
in cell order that is about its own range), so only that window is cleared and summed: with two
chunks each buffer pass touches about half of what whole buffers would. Laws: see
`laws/dispatch.py`.
Lever arms follow LIGGGHTS: the contact point lies r - delta/2 from each centre.
A pair that separates has its springs reset to zero, unless the pair's materials use
LIGGGHTS' forms (``SimParams.contact_forms == 'liggghts'``, TAB_FORMS): LIGGGHTS 3.8 keeps a
sphere pair's history while the pair stays in its neighbour list (its ``surfacesClose``, which
would clear it, runs only for pairs within ``contactDistanceFactor`` radii, 1 by default, which
the touching branch takes first), so a pair that parts and touches again before the next list
build resumes its old springs; the build drops them (`history.carry_sources`).
The springs lie in rows for the touching pairs only (`history.py`): entry k's row is slot[k]; a
pair that starts touching takes the row at its chunk's tail, one that parts (dempath's forms)
frees its row.
With sleeping grains (`sleep.py`) a pair of two sleeping grains, neither on the rim, is skipped
with its springs kept; a touching pair of one sleeping and one awake grain marks the sleeping one
as touched (rim at the next step) and, when the awake one moves faster than the wake speed, to be
woken. `evals` counts the pairs evaluated (their distance computed) per chunk.
"""

from __future__ import annotations

import math

from numba import njit, prange

from dempath_sim.engine.laws.cohesion_sjkr import sjkr_area_pair
from dempath_sim.engine.laws.dispatch import TAB_FORMS, resolve_contact


@njit(parallel=True, fastmath=True, cache=True)
def pair_forces(pos, vel, omg, rad, mass, mat, start, nbr, slot, ht, hr, tail, live, tab, dt,
                rolling, cohesion, fbuf, tbuf, window, worst, sleeping, asleep, rim, touch, wake,
                v_wake, evals):  # pragma: no cover - compiled
    """Accumulate particle-particle forces and torques into per-chunk buffers.

    Args:
        pos, vel, omg: (n, 3) positions [m], velocities [m/s], angular velocities [rad/s].
        rad, mass: (n,) radii [m] and masses [kg].
        mat: (n,) int32 material indices.
        start: (n + 1,) int64 CSR offsets of the half neighbour list.
        nbr: (m,) int32 neighbour j > i of each list entry.
        slot: (m,) int32 history row of each list entry, -1 for none (updated).
        ht, hr: (rows, 3) tangential [m] and rolling [N m] springs (`history.PairHistory`).
        tail: (n_chunks,) int64 next free row of each chunk's region (advanced).
        live: (n_chunks,) int64 out: entries with a row after the pass, per chunk.
        tab: Pair table (see contact.build_pair_table).
        dt: Time step [s].
        rolling, cohesion: Switches of the optional laws.
        fbuf, tbuf: (n_chunks, n, 3) force [N] and torque [N m] buffers (rows of each chunk's
            window overwritten, the others left as they are).
        window: (n_chunks, 2) int64 rows [lo, hi) each chunk writes (see `chunk_windows`).
        worst: (n_chunks, 3) out: largest overlap / smaller radius and the pair (i, j).
        sleeping: Whether grains may sleep (False: the flags below are not read).
        asleep, rim: (n,) uint8 sleeping grains and sleeping grains on the rim.
        touch, wake: (n,) uint8 out (set, never cleared here): sleeping grains touching an
            awake one, and those whose awake neighbour moves faster than v_wake [m/s].
        evals: (n_chunks,) int64 out: pairs evaluated.
    """
    n_chunks = fbuf.shape[0]
    n = pos.shape[0]
    for c in prange(n_chunks):
        fb = fbuf[c]
        tb = tbuf[c]
        for i in range(window[c, 0], window[c, 1]):
            for q in range(3):
                fb[i, q] = 0.0
                tb[i, q] = 0.0
        w_ratio = 0.0
        w_i = -1
        w_j = -1
        count = 0
        row_next = tail[c]
        rows = 0
        v_wake2 = v_wake * v_wake
        for i in range(c * n // n_chunks, (c + 1) * n // n_chunks):
            for k in range(start[i], start[i + 1]):
                j = nbr[k]
                if sleeping and asleep[i] and asleep[j] and not (rim[i] or rim[j]):
                    if slot[k] >= 0:
                        rows += 1
                    continue  # frozen pair: same force at every step, springs kept
                count += 1
                dx = pos[i, 0] - pos[j, 0]
                dy = pos[i, 1] - pos[j, 1]
                dz = pos[i, 2] - pos[j, 2]
                d2 = dx * dx + dy * dy + dz * dz
                rs = rad[i] + rad[j]
                if d2 >= rs * rs:
                    if slot[k] >= 0:
                        if tab[mat[i], mat[j], TAB_FORMS] == 0.0:
                            slot[k] = -1  # just separated: springs reset (row freed)
                        else:
                            rows += 1
                    continue
                s = slot[k]
                if s < 0:  # a new contact: the next row of the chunk, springs from zero
                    s = row_next
                    row_next += 1
                    slot[k] = s
                    for q in range(3):
                        ht[s, q] = 0.0
                        hr[s, q] = 0.0
                rows += 1
                if sleeping and asleep[i] != asleep[j]:
                    s_ = i if asleep[i] else j  # the sleeping grain and the awake one
                    a_ = j if asleep[i] else i
                    touch[s_] = 1
                    if vel[a_, 0] ** 2 + vel[a_, 1] ** 2 + vel[a_, 2] ** 2 > v_wake2:
                        wake[s_] = 1
                d = math.sqrt(d2)
                delta = rs - d
                r_min = min(rad[i], rad[j])
                if delta > w_ratio * r_min:  # the division only for a new worst overlap
                    w_ratio = delta / r_min
                    w_i = i
                    w_j = j
                nx = dx / d
                ny = dy / d
                nz = dz / d
                li = rad[i] - 0.5 * delta  # lever arm of i (contact point at -li n)
                lj = rad[j] - 0.5 * delta  # lever arm of j (contact point at +lj n)
                # v_rel = v_i + w_i x (-li n) - v_j - w_j x (lj n)
                cx = -(li * omg[i, 0] + lj * omg[j, 0])
                cy = -(li * omg[i, 1] + lj * omg[j, 1])
                cz = -(li * omg[i, 2] + lj * omg[j, 2])
                vx = vel[i, 0] - vel[j, 0] + cy * nz - cz * ny
                vy = vel[i, 1] - vel[j, 1] + cz * nx - cx * nz
                vz = vel[i, 2] - vel[j, 2] + cx * ny - cy * nx
                area = sjkr_area_pair(d, rad[i], rad[j]) if cohesion else 0.0
                r_eff = rad[i] * rad[j] / rs
                m_eff = mass[i] * mass[j] / (mass[i] + mass[j])
                fx, fy, fz, mx, my, mz, _ = resolve_contact(
                    tab, mat[i], mat[j], delta, r_eff, m_eff, area, nx, ny, nz, vx, vy, vz,
                    omg[i, 0] - omg[j, 0], omg[i, 1] - omg[j, 1], omg[i, 2] - omg[j, 2],
                    ht, hr, s, dt, rolling)
                fb[i, 0] += fx
                fb[i, 1] += fy
                fb[i, 2] += fz
                fb[j, 0] -= fx
                fb[j, 1] -= fy
                fb[j, 2] -= fz
                # torque = lever x F with lever -li n (i) and +lj n (j, force -F): both -l n x F
                tx = ny * fz - nz * fy
                ty = nz * fx - nx * fz
                tz = nx * fy - ny * fx
                tb[i, 0] += -li * tx + mx
                tb[i, 1] += -li * ty + my
                tb[i, 2] += -li * tz + mz
                tb[j, 0] += -lj * tx - mx
                tb[j, 1] += -lj * ty - my
                tb[j, 2] += -lj * tz - mz
        worst[c, 0] = w_ratio
        worst[c, 1] = w_i
        worst[c, 2] = w_j
        evals[c] = count
        tail[c] = row_next
        live[c] = rows


@njit(cache=True)
def chunk_windows(start, nbr, window):  # pragma: no cover - compiled
    """window[c] = [first particle of chunk c, 1 + the highest particle its pairs reach) for the
    chunks of `pair_forces` over the half list (start, nbr); window (n_chunks, 2) int64 out."""
    n_chunks = window.shape[0]
    n = start.shape[0] - 1
    for c in range(n_chunks):
        lo = c * n // n_chunks
        hi = (c + 1) * n // n_chunks
        top = hi
        for k in range(start[lo], start[hi]):
            top = max(top, nbr[k] + 1)
        window[c, 0] = lo
        window[c, 1] = top


@njit(parallel=True, cache=True)
def reduce_buffers(fbuf, tbuf, window, force, torque):  # pragma: no cover - compiled
    """force[i] = sum_c fbuf[c, i], torque[i] = sum_c tbuf[c, i] over the chunks whose window
    holds row i (the others did not write it; overwrites force, torque)."""
    n_chunks = fbuf.shape[0]
    for i in prange(force.shape[0]):
        for q in range(3):
            f = 0.0
            t = 0.0
            for c in range(n_chunks):
                if window[c, 0] <= i < window[c, 1]:
                    f += fbuf[c, i, q]
                    t += tbuf[c, i, q]
            force[i, q] = f
            torque[i, q] = t
