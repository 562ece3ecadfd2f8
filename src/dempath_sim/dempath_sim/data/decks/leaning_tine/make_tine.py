"""Write the leaning tine of the hand-written LIGGGHTS deck: ``tine.stl`` and ``tine_cut.in``.

The tine is a flat steel plate leaning forward: its front face rises backwards from the tip at
ALPHA to the horizontal (the bottom leads, the top trails), it is WIDTH wide (X) and THICKNESS
thick (normal to its faces), with horizontal bottom and top faces. It is one closed hexahedron
of 12 triangles with outward normals, in the tool frame: the tip (centre of the lowest front
edge) at the origin, Y up, travel along +Z, metres. LIGGGHTS places it with
``fix mesh/surface ... move`` and dempath with the scene's tool keys, so both read this file.

``tine_cut.in`` defines ``region tinecut``: the tine at its start position grown by the largest
particle radius (six half-spaces), so that ``delete_atoms region tinecut`` removes every particle
that overlaps the tine after the insertion (and a few near its edges that do not).

Run: ``python make_tine.py`` (writes both files beside itself).
"""

from __future__ import annotations

import math
from pathlib import Path

ALPHA = math.radians(60.0)  # front face to the horizontal (30 deg lean from vertical)
WIDTH = 0.050  # m, X
THICKNESS = 0.012  # m, normal to the faces
HEIGHT = 0.170  # m, Y from the tip to the top face
TIP = (0.0, -0.070, 0.150)  # m, tip at the start of the pass (world frame of the deck)
R_MAX = 0.00495  # m, largest particle radius of the deck


def corners() -> list[tuple[float, float, float]]:
    """Eight corners (x, y, z) of the tine in the tool frame, bottom face first."""
    back = THICKNESS / math.sin(ALPHA)  # horizontal thickness of the plate
    run = HEIGHT / math.tan(ALPHA)  # how far the top trails the tip
    w = WIDTH / 2
    out = []
    for y, z0 in ((0.0, 0.0), (HEIGHT, -run)):
        out += [(-w, y, z0), (w, y, z0), (w, y, z0 - back), (-w, y, z0 - back)]
    return out


# Quads as corner indices, counter-clockwise seen from outside.
QUADS = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (2, 3, 7, 6), (1, 2, 6, 5), (3, 0, 4, 7))


def triangles() -> list[tuple[tuple[float, float, float], ...]]:
    """Twelve triangles of the closed tine, outward winding."""
    c = corners()
    tris: list[tuple[tuple[float, float, float], ...]] = []
    for a, b, d, e in QUADS:
        tris += [(c[a], c[b], c[d]), (c[a], c[d], c[e])]
    return tris


def normal(tri: tuple[tuple[float, float, float], ...]) -> tuple[float, float, float]:
    """Unit normal of a triangle from its winding."""
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = tri
    u, v = (bx - ax, by - ay, bz - az), (cx - ax, cy - ay, cz - az)
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    s = math.sqrt(sum(k * k for k in n))
    return (n[0] / s, n[1] / s, n[2] / s)


def stl_text() -> str:
    """ASCII STL of the tine (LIGGGHTS reads ASCII STL only)."""
    lines = ['solid tine']
    for tri in triangles():
        lines.append(' facet normal {:.9g} {:.9g} {:.9g}'.format(*normal(tri)))
        lines.append('  outer loop')
        lines += ['   vertex {:.9g} {:.9g} {:.9g}'.format(*p) for p in tri]
        lines += ['  endloop', ' endfacet']
    return '\n'.join([*lines, 'endsolid tine']) + '\n'


def cut_region_text() -> str:
    """``region tinecut``: the tine at TIP grown by R_MAX, as an intersection of half-spaces."""
    x0, y0, z0 = TIP
    c, s = math.cos(ALPHA), math.sin(ALPHA)
    nf = (0.0, c, s)  # outward normal of the front face
    g = R_MAX
    planes = {
        'tc_bottom': ((x0, y0 - g, z0), (0, 1, 0)),
        'tc_top': ((x0, y0 + HEIGHT + g, z0), (0, -1, 0)),
        'tc_left': ((x0 - WIDTH / 2 - g, y0, z0), (1, 0, 0)),
        'tc_right': ((x0 + WIDTH / 2 + g, y0, z0), (-1, 0, 0)),
        'tc_front': ((x0, y0 + g * nf[1], z0 + g * nf[2]), (0, -nf[1], -nf[2])),
        'tc_back': ((x0, y0 - (THICKNESS + g) * nf[1], z0 - (THICKNESS + g) * nf[2]),
                    (0, nf[1], nf[2])),
    }
    lines = ['# Written by make_tine.py: the tine at its start position grown by the largest',
             '# particle radius; particles whose centres lie inside overlap (or nearly touch) it.']
    for name, (p, n) in planes.items():
        lines.append(f'region {name} plane {p[0]:.9g} {p[1]:.9g} {p[2]:.9g} '
                     f'{n[0]:.9g} {n[1]:.9g} {n[2]:.9g} side in units box')
    lines.append(f'region tinecut intersect {len(planes)} {" ".join(planes)} units box')
    return '\n'.join(lines) + '\n'


def main() -> None:
    """Write tine.stl and tine_cut.in beside this script."""
    here = Path(__file__).resolve().parent
    (here / 'tine.stl').write_text(stl_text())
    (here / 'tine_cut.in').write_text(cut_region_text())


if __name__ == '__main__':
    main()
