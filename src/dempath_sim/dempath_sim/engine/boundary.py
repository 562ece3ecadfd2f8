# mypy: disable-error-code="no-untyped-def"
"""Particle-plane and particle-triangle-mesh contact forces (one parallel per-particle loop).

Each particle tests the planes and the tool triangles of its grid cell (tool frame), keeping the
MAX_CANDIDATES nearest triangles within its radius. Contacts with one mesh are grouped into
patches so that a flat or convex patch made of several triangles acts once: the candidate closest
points are taken nearest first, and a candidate is shadowed by (joins the patch of) the first
kept contact whose tangent plane it does not lie above ((q_b - q_a) . n_a <= tol); concave
corners (two faces facing the particle) keep both contacts. An edge or vertex shared by several
triangles thus gives one contact, as LIGGGHTS handles a contact on a shared edge or corner once
per surface (SurfaceMesh coplanar neighbours, FixContactHistoryMesh `coplanarContactAlready`).
Contact history lives in N_SLOTS slots per particle keyed by plane index or n_planes + triangle
index. A patch keeps its history when its closest feature moves to another triangle: if the
nearest triangle has no slot but a triangle of its patch held one at the previous step, that slot
is re-keyed (LIGGGHTS transfers the shear history between coplanar neighbour faces for the same
reason; with dempath's forms any triangle of the patch qualifies, so convex edges pass it on too;
with LIGGGHTS' forms only a coplanar neighbour face, or a triangle whose closest point is the
same point (the contact sits on their shared edge or corner), as LIGGGHTS 3.8 copies a new face
contact's history from a coplanar neighbour only, so a contact that slides round a convex edge
onto the next face starts a fresh spring there). The carried
springs are projected on the new tangent plane with their length kept, as between steps (see
`laws/hertz_mindlin.py`). When all slots are busy the contact runs without history (counted
in `worst[:, 3]`).
Laws (same as particle-particle, per-pair materials): see `laws/dispatch.py`, with R* = r and
m* = m (rigid, infinitely heavy wall). The contact point lies at the wall surface, r - delta from
the centre; with LIGGGHTS' forms (``SimParams.contact_forms``) the lever arm of the contact
velocity and torque is r - delta / 2, and the rolling spring grows with omega (r - delta / 2) /
(r - delta), as LIGGGHTS 3.8 takes them for wall contacts (its `epsd2` uses the scaled wall spin).
The reaction on the tool is summed per chunk: force (3,) and torque (3,)
about the tool origin. The pass runs over a given list of particles: the engine passes those
within reach of a plane or the tool until its next list build (`reach.reach_candidates`), having
cleared the history slots of the others, which the full pass would clear at this step too.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from dempath_sim.engine.laws.cohesion_sjkr import sjkr_area_wall
from dempath_sim.engine.laws.dispatch import TAB_FORMS, resolve_contact
from dempath_sim.engine.mesh import closest_point_triangle, coplanar_neighbours

N_SLOTS = 4  # geometry contacts with history per particle
MAX_CANDIDATES = 16  # mesh triangles within reach of one particle


@njit(cache=True)
def find_slot(keys, i, key, used):  # pragma: no cover - compiled
    """History slot of contact `key` for particle i (claims a free one); -1 if all are busy."""
    for s in range(keys.shape[1]):
        if keys[i, s] == key:
            return s
    for s in range(keys.shape[1]):
        if keys[i, s] == -1 and not (used >> s) & 1:
            keys[i, s] = key
            return s
    return -1


@njit(fastmath=True, cache=True)
def _apply(i, c, key, s, delta, lever, nx, ny, nz, vx, vy, vz, wx, wy, wz, a, b, rad, mass,
           gkey, ght, ghr, tmp_t, tmp_r, tab, dt, rolling, cohesion, used,
           force, torque, worst):  # pragma: no cover - compiled
    """Resolve geometry contact `key` of particle i with history slot s (-1: none).

    Returns:
        (fx, fy, fz, mx, my, mz, used): force [N] and rolling torque [N m] on i, slot mask.
    """
    ht = ght  # ght, ghr are the (n * N_SLOTS, 3) flat views: no array views made per contact
    hr = ghr
    row = i * gkey.shape[1] + s
    if s >= 0:
        used |= 1 << s
    else:
        worst[c, 3] += 1.0
        for q in range(3):
            tmp_t[c, q] = 0.0
            tmp_r[c, q] = 0.0
        ht = tmp_t
        hr = tmp_r
        row = c
    area = sjkr_area_wall(rad[i], delta) if cohesion else 0.0
    fx, fy, fz, mx, my, mz, _ = resolve_contact(
        tab, a, b, delta, rad[i], mass[i], area, nx, ny, nz, vx, vy, vz, wx, wy, wz,
        ht, hr, row, dt, rolling)
    ratio = delta / rad[i]
    if ratio > worst[c, 0]:
        worst[c, 0] = ratio
        worst[c, 1] = i
        worst[c, 2] = -1 - key
    force[i, 0] += fx
    force[i, 1] += fy
    force[i, 2] += fz
    torque[i, 0] += -lever * (ny * fz - nz * fy) + mx
    torque[i, 1] += -lever * (nz * fx - nx * fz) + my
    torque[i, 2] += -lever * (nx * fy - ny * fx) + mz
    return fx, fy, fz, mx, my, mz, used


@njit(inline='always', cache=True)
def _lever(tab, a, b, r, d):  # pragma: no cover - compiled
    """(lever arm [m], spin scale for the rolling spring [-]) of a geometry contact at distance
    d < r from the centre: (d, 1), or ((r + d) / 2, (r + d) / (2 d)) with LIGGGHTS' forms."""
    if tab[a, b, TAB_FORMS] > 0.0:
        return 0.5 * (r + d), (0.5 * (r + d) / d if d > 0.0 else 1.0)
    return d, 1.0


@njit(fastmath=True, cache=True)
def _plane_contact(i, c, p, s, pos, vel, omg, rad, mass, mat, planes, plane_mat, gkey, ght,
                   ghr, tmp_t, tmp_r, tab, dt, rolling, cohesion, used, force, torque,
                   worst):  # pragma: no cover - compiled
    """Contact of particle i with plane p at signed distance s < r; returns the slot mask."""
    nx, ny, nz = planes[p, 3], planes[p, 4], planes[p, 5]
    lev, ws = _lever(tab, mat[i], np.int64(plane_mat[p]), rad[i], s)
    # v_rel = v_i + w_i x (-lev n)
    vx = vel[i, 0] - lev * (omg[i, 1] * nz - omg[i, 2] * ny)
    vy = vel[i, 1] - lev * (omg[i, 2] * nx - omg[i, 0] * nz)
    vz = vel[i, 2] - lev * (omg[i, 0] * ny - omg[i, 1] * nx)
    r = _apply(i, c, p, find_slot(gkey, i, p, used), rad[i] - s, lev, nx, ny, nz, vx, vy, vz,
               ws * omg[i, 0], ws * omg[i, 1], ws * omg[i, 2], mat[i], np.int64(plane_mat[p]),
               rad, mass,
               gkey, ght, ghr, tmp_t, tmp_r, tab, dt, rolling, cohesion, used, force, torque,
               worst)
    return r[6]


@njit(fastmath=True, cache=True)
def _collect_candidates(px, py, pz, r, tris, g_lo, g_cell, g_dims, g_start, g_tris,
                        cand):  # pragma: no cover - compiled
    """Triangles within r of p (tool frame), nearest first into cand (rows: t, d2, q); the
    MAX_CANDIDATES nearest are kept."""
    gx = int((px - g_lo[0]) / g_cell)
    gy = int((py - g_lo[1]) / g_cell)
    gz = int((pz - g_lo[2]) / g_cell)
    if px < g_lo[0] or py < g_lo[1] or pz < g_lo[2]:
        return 0
    if gx >= g_dims[0] or gy >= g_dims[1] or gz >= g_dims[2]:
        return 0
    cell = (gx * g_dims[1] + gy) * g_dims[2] + gz
    nc = 0
    for q in range(g_start[cell], g_start[cell + 1]):
        t = g_tris[q]
        qx, qy, qz = closest_point_triangle(px, py, pz, tris[t])
        d2 = (px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2
        if d2 >= r * r or d2 == 0.0:
            continue
        if nc < cand.shape[0]:
            pos = nc
            nc += 1
        elif d2 < cand[nc - 1, 1]:
            pos = nc - 1  # full: the farthest candidate gives way
        else:
            continue
        while pos > 0 and cand[pos - 1, 1] > d2:  # insertion sort, nearest first
            for col in range(5):
                cand[pos, col] = cand[pos - 1, col]
            pos -= 1
        cand[pos, 0] = t
        cand[pos, 1] = d2
        cand[pos, 2] = qx
        cand[pos, 3] = qy
        cand[pos, 4] = qz
    return nc


@njit(inline='always', fastmath=True, cache=True)
def plane_distance(planes, p, x, y, z):  # pragma: no cover - compiled
    """Signed distance [m] of the point (x, y, z) from plane p, positive inside."""
    return ((x - planes[p, 0]) * planes[p, 3] + (y - planes[p, 1]) * planes[p, 4]
            + (z - planes[p, 2]) * planes[p, 5])


@njit(inline='always', fastmath=True, cache=True)
def to_tool_frame(tool, x, y, z):  # pragma: no cover - compiled
    """The world point (x, y, z) [m] in the tool frame of the packed pose tool (18,):
    R^T (x - t), R stored row-major in tool[9:18]."""
    rx = x - tool[0]
    ry = y - tool[1]
    rz = z - tool[2]
    return (tool[9] * rx + tool[12] * ry + tool[15] * rz,
            tool[10] * rx + tool[13] * ry + tool[16] * rz,
            tool[11] * rx + tool[14] * ry + tool[17] * rz)


@njit(inline='always', fastmath=True, cache=True)
def _in_grid(x, y, z, tool, g_lo, g_hi0, g_hi1, g_hi2):  # pragma: no cover - compiled
    """Whether the world point (x, y, z) lies inside the triangle grid's box (tool frame)."""
    px, py, pz = to_tool_frame(tool, x, y, z)
    return (g_lo[0] <= px < g_hi0) and (g_lo[1] <= py < g_hi1) and (g_lo[2] <= pz < g_hi2)


@njit(fastmath=True, cache=True)
def _group_patches(px, py, pz, nc, cand, tol):  # pragma: no cover - compiled
    """Sort candidates into patches: cand[b, 5] = -1 keeps b, a >= 0 puts it in a's patch.

    Also writes the unit normal from the closest point to p into cand[b, 6:9] (tool frame).
    """
    for b in range(nc):
        d = cand[b, 1] ** 0.5
        cand[b, 6] = (px - cand[b, 2]) / d
        cand[b, 7] = (py - cand[b, 3]) / d
        cand[b, 8] = (pz - cand[b, 4]) / d
        cand[b, 5] = -1.0
        for a in range(b):
            if cand[a, 5] < 0.0 and ((cand[b, 2] - cand[a, 2]) * cand[a, 6]
                                     + (cand[b, 3] - cand[a, 3]) * cand[a, 7]
                                     + (cand[b, 4] - cand[a, 4]) * cand[a, 8]) <= tol:
                cand[b, 5] = a  # shadowed by a nearer contact (same patch or convex edge)
                break


@njit(cache=True)
def _same_contact(tris, cand, a, b):  # pragma: no cover - compiled
    """LIGGGHTS' forms: whether the contact at candidate a continues the one at b: both closest
    points are one point (the contact sits on the edge or corner the two triangles share, which
    LIGGGHTS gives to one triangle, whose contact goes on), or the faces are coplanar neighbours
    (LIGGGHTS' ``checkCoplanarContactHistory``)."""
    dx = cand[a, 2] - cand[b, 2]
    dy = cand[a, 3] - cand[b, 3]
    dz = cand[a, 4] - cand[b, 4]
    if dx * dx + dy * dy + dz * dz <= 1e-18 * cand[a, 1]:
        return True
    return coplanar_neighbours(tris, int(cand[a, 0]), int(cand[b, 0]))


@njit(cache=True)
def patch_slot(gkey, i, a, cand, nc, n_planes, used, tris,
               coplanar_only):  # pragma: no cover - compiled
    """History slot of the patch kept at candidate a of particle i; -1 if all slots are busy.

    The slot of a's own triangle if it has one; else the unused slot of a triangle of a's
    patch (the contact slid over an edge or vertex: the slot is re-keyed to a's triangle, so
    its springs carry over; with ``coplanar_only``, LIGGGHTS' forms, only where the contact
    goes on (``_same_contact``), so that one sliding round a convex edge onto the next face
    starts afresh, as in LIGGGHTS 3.8); else a free slot.
    """
    key = n_planes + int(cand[a, 0])
    for s in range(gkey.shape[1]):
        if gkey[i, s] == key:
            return s
    for b in range(a + 1, nc):
        if cand[b, 5] != a or (coplanar_only and not _same_contact(tris, cand, a, b)):
            continue
        old = n_planes + int(cand[b, 0])
        for s in range(gkey.shape[1]):
            if gkey[i, s] == old and not (used >> s) & 1:
                gkey[i, s] = key
                return s
    return find_slot(gkey, i, key, used)


@njit(fastmath=True, cache=True)
def _mesh_contacts(i, c, pos, vel, omg, rad, mass, mat, tris, tri_mat, n_planes, g_lo, g_cell,
                   g_dims, g_start, g_tris, tool, gkey, ght, ghr, tmp_t, tmp_r, tab, dt, rolling,
                   cohesion, used, force, torque, worst, cand,
                   tool_acc):  # pragma: no cover - compiled
    """All tool-mesh contacts of particle i, one per patch; tool: (18,) (see boundary_forces)."""
    px, py, pz = to_tool_frame(tool, pos[i, 0], pos[i, 1], pos[i, 2])
    nc = _collect_candidates(px, py, pz, rad[i], tris, g_lo, g_cell, g_dims, g_start, g_tris,
                             cand)
    _group_patches(px, py, pz, nc, cand, 1e-6 * rad[i])
    forms = tab[mat[i], tri_mat, TAB_FORMS]
    for b in range(nc):
        if cand[b, 5] >= 0.0:
            continue
        d = cand[b, 1] ** 0.5
        lnx, lny, lnz = cand[b, 6], cand[b, 7], cand[b, 8]
        nx = tool[9] * lnx + tool[10] * lny + tool[11] * lnz
        ny = tool[12] * lnx + tool[13] * lny + tool[14] * lnz
        nz = tool[15] * lnx + tool[16] * lny + tool[17] * lnz
        cx = pos[i, 0] - d * nx - tool[0]  # contact point relative to the tool origin
        cy = pos[i, 1] - d * ny - tool[1]
        cz = pos[i, 2] - d * nz - tool[2]
        lev, ws = _lever(tab, mat[i], tri_mat, rad[i], d)
        vx = vel[i, 0] - lev * (omg[i, 1] * nz - omg[i, 2] * ny) - (tool[3] + tool[7] * cz
                                                                     - tool[8] * cy)
        vy = vel[i, 1] - lev * (omg[i, 2] * nx - omg[i, 0] * nz) - (tool[4] + tool[8] * cx
                                                                     - tool[6] * cz)
        vz = vel[i, 2] - lev * (omg[i, 0] * ny - omg[i, 1] * nx) - (tool[5] + tool[6] * cy
                                                                     - tool[7] * cx)
        fx, fy, fz, mx, my, mz, used = _apply(
            i, c, n_planes + int(cand[b, 0]),
            patch_slot(gkey, i, b, cand, nc, n_planes, used, tris, forms > 0.0),
            rad[i] - d, lev, nx, ny, nz, vx, vy, vz,
            ws * (omg[i, 0] - tool[6]), ws * (omg[i, 1] - tool[7]), ws * (omg[i, 2] - tool[8]),
            mat[i], tri_mat,
            rad, mass, gkey, ght, ghr, tmp_t, tmp_r, tab, dt, rolling, cohesion, used,
            force, torque, worst)
        tool_acc[c, 0] -= fx
        tool_acc[c, 1] -= fy
        tool_acc[c, 2] -= fz
        tool_acc[c, 3] -= cy * fz - cz * fy + mx
        tool_acc[c, 4] -= cz * fx - cx * fz + my
        tool_acc[c, 5] -= cx * fy - cy * fx + mz
    return used


@njit(fastmath=True, cache=True)
def _boundary_chunk(c, pos, vel, omg, rad, mass, mat, planes, plane_mat, tris, mat_tool, g_lo,
                    g_cell, g_dims, g_start, g_tris, tool, gkey, ght, ghr, tab, dt, rolling,
                    cohesion, force, torque, tool_acc, worst, cand, tmp_t,
                    tmp_r, idx):  # pragma: no cover - compiled
    """The work of chunk c of `boundary_forces` (idx[c m / n_chunks ...]); ght, ghr flat."""
    n_chunks = tool_acc.shape[0]
    m = idx.shape[0]
    n_planes = planes.shape[0]
    n_slots = gkey.shape[1]
    has_tool = tris.shape[0] > 0
    g_hi0 = g_lo[0] + g_dims[0] * g_cell
    g_hi1 = g_lo[1] + g_dims[1] * g_cell
    g_hi2 = g_lo[2] + g_dims[2] * g_cell
    for q in range(6):
        tool_acc[c, q] = 0.0
    for q in range(c * m // n_chunks, (c + 1) * m // n_chunks):
        i = idx[q]
        used = np.int64(0)
        for p in range(n_planes):
            s = plane_distance(planes, p, pos[i, 0], pos[i, 1], pos[i, 2])
            if s < rad[i]:
                used = _plane_contact(i, c, p, s, pos, vel, omg, rad, mass, mat, planes,
                                      plane_mat, gkey, ght, ghr, tmp_t, tmp_r, tab, dt,
                                      rolling, cohesion, used, force, torque, worst)
        if has_tool and _in_grid(pos[i, 0], pos[i, 1], pos[i, 2], tool, g_lo, g_hi0, g_hi1,
                                 g_hi2):
            used = _mesh_contacts(i, c, pos, vel, omg, rad, mass, mat, tris, mat_tool,
                                  n_planes, g_lo, g_cell, g_dims, g_start, g_tris, tool,
                                  gkey, ght, ghr, tmp_t, tmp_r, tab, dt, rolling, cohesion,
                                  used, force, torque, worst, cand, tool_acc)
        for k in range(n_slots):
            if not (used >> k) & 1 and gkey[i, k] != -1:
                gkey[i, k] = -1
                for q in range(3):
                    ght[i * n_slots + k, q] = 0.0
                    ghr[i * n_slots + k, q] = 0.0


@njit(cache=True)
def _boundary_chunk_packed(c, args):  # pragma: no cover - compiled
    """`_boundary_chunk(c, *args)`."""
    _boundary_chunk(c, *args)


@njit(parallel=True, fastmath=True, cache=True)
def boundary_forces(pos, vel, omg, rad, mass, mat, planes, plane_mat, tris, tri_mat, g_lo,
                    g_cell, g_dims, g_start, g_tris, tool, gkey, ght, ghr, tab, dt, rolling,
                    cohesion, force, torque, tool_acc, worst, cand, tmp_t, tmp_r,
                    idx):  # pragma: no cover - compiled
    """Add plane and tool-mesh contact forces to force/torque (n, 3); tool reaction per chunk.

    Args:
        pos, vel, omg, rad, mass, mat: Particle arrays (see SimState).
        planes: (n_planes, 6) point and inward unit normal; plane_mat: (n_planes,) materials.
        tris: (n_tri, 3, 3) tool triangles in the tool frame [m]; tri_mat: tool material.
        g_lo, g_cell, g_dims, g_start, g_tris: Triangle grid (see mesh.TriangleGrid).
        tool: (18,) tool position [m], velocity [m/s], angular velocity [rad/s], rotation
            tool->world row-major.
        gkey, ght, ghr: (n, N_SLOTS) contact keys and (n, N_SLOTS, 3) springs.
        tab, dt, rolling, cohesion: Pair table, time step [s] and law switches.
        force, torque: (n, 3) accumulated in place [N], [N m].
        tool_acc: (n_chunks, 6) out: force [N] and torque [N m] on the tool.
        worst: (n_chunks, 4) in/out: largest overlap ratio, i, -1-key, slot overflows.
        cand: (n_chunks, MAX_CANDIDATES, 9) scratch; tmp_t, tmp_r: (n_chunks, 1, 3) scratch.
        idx: (m,) int64 particles to test, ascending (all: arange(n); or the candidates of
            `reach_candidates`, whose other particles have no geometry contact now).
    """
    n_chunks = tool_acc.shape[0]
    n = pos.shape[0]
    n_slots = gkey.shape[1]
    ght = ght.reshape((n * n_slots, 3))  # one row per (particle, slot)
    ghr = ghr.reshape((n * n_slots, 3))
    tmp_t = tmp_t.reshape((n_chunks, 3))
    tmp_r = tmp_r.reshape((n_chunks, 3))
    # The parallel loop body is one call taking one tuple: numba's parfor lowering of a body
    # that references ~30 arrays took ~45 s CPU to compile; with the tuple it takes ~5 s.
    a = (pos, vel, omg, rad, mass, mat, planes, plane_mat, tris, np.int64(tri_mat), g_lo,
         g_cell, g_dims, g_start, g_tris, tool, gkey, ght, ghr, tab, dt, rolling, cohesion,
         force, torque, tool_acc, worst)
    for c in prange(n_chunks):
        _boundary_chunk_packed(np.int64(c), (*a, cand[c], tmp_t, tmp_r, idx))
