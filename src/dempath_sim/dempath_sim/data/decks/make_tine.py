"""Write the tines of the hand-written LIGGGHTS decks: ``tine.stl`` and ``tine_cut.in`` of each.

Each tine is a flat steel bar leaning forward: its front face rises backwards from the tip at
``alpha`` to the horizontal (the bottom leads, the top trails), it is ``width`` wide (X) and
``thickness`` thick (normal to its faces), with horizontal bottom and top faces. It is one closed
hexahedron of 12 triangles with outward normals, in the tool frame: the tip (centre of the lowest
front edge) at the origin, Y up, travel along +Z, metres. LIGGGHTS places it with
``fix mesh/surface ... move`` and dempath with the scene's tool keys, so both read this file.

``tine_cut.in`` defines ``region tinecut``: the tine at its start position grown by the largest
particle radius (six half-spaces), so that ``delete_atoms region tinecut`` removes every particle
that overlaps the tine after the insertion (and a few near its edges that do not).

Decks: ``leaning_tine`` (a 50 mm plate leaning 30 deg, tip 70 mm deep) and ``raked_tine`` (a
35 mm bar leaning 25 deg, tip 80 mm deep).

Run: ``python make_tine.py`` (writes both files into each deck's folder).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Tine:
    """One deck's tine: alpha (front face to the horizontal) [rad], width (X), thickness (normal
    to the faces), height (Y, tip to top) [m], the tip's start position [m] and the deck's
    largest particle radius [m]."""

    alpha: float
    width: float
    thickness: float
    height: float
    tip: tuple[float, float, float]
    r_max: float


TINES = {
    'leaning_tine': Tine(math.radians(60.0), 0.050, 0.012, 0.170, (0.0, -0.070, 0.150), 0.00495),
    'raked_tine': Tine(math.radians(65.0), 0.035, 0.012, 0.160, (0.0, -0.080, 0.100), 0.0040),
}


def corners(t: Tine) -> list[tuple[float, float, float]]:
    """Eight corners (x, y, z) of the tine in the tool frame, bottom face first."""
    back = t.thickness / math.sin(t.alpha)  # horizontal thickness of the bar
    run = t.height / math.tan(t.alpha)  # how far the top trails the tip
    w = t.width / 2
    out = []
    for y, z0 in ((0.0, 0.0), (t.height, -run)):
        out += [(-w, y, z0), (w, y, z0), (w, y, z0 - back), (-w, y, z0 - back)]
    return out


# Quads as corner indices, counter-clockwise seen from outside.
QUADS = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (2, 3, 7, 6), (1, 2, 6, 5), (3, 0, 4, 7))


def triangles(t: Tine) -> list[tuple[tuple[float, float, float], ...]]:
    """Twelve triangles of the closed tine, outward winding."""
    c = corners(t)
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


def stl_text(t: Tine) -> str:
    """ASCII STL of the tine (LIGGGHTS reads ASCII STL only)."""
    lines = ['solid tine']
    for tri in triangles(t):
        lines.append(' facet normal {:.9g} {:.9g} {:.9g}'.format(*normal(tri)))
        lines.append('  outer loop')
        lines += ['   vertex {:.9g} {:.9g} {:.9g}'.format(*p) for p in tri]
        lines += ['  endloop', ' endfacet']
    return '\n'.join([*lines, 'endsolid tine']) + '\n'


def cut_region_text(t: Tine) -> str:
    """``region tinecut``: the tine at its tip grown by r_max, as an intersection of
    half-spaces."""
    x0, y0, z0 = t.tip
    c, s = math.cos(t.alpha), math.sin(t.alpha)
    nf = (0.0, c, s)  # outward normal of the front face
    g = t.r_max
    planes = {
        'tc_bottom': ((x0, y0 - g, z0), (0, 1, 0)),
        'tc_top': ((x0, y0 + t.height + g, z0), (0, -1, 0)),
        'tc_left': ((x0 - t.width / 2 - g, y0, z0), (1, 0, 0)),
        'tc_right': ((x0 + t.width / 2 + g, y0, z0), (-1, 0, 0)),
        'tc_front': ((x0, y0 + g * nf[1], z0 + g * nf[2]), (0, -nf[1], -nf[2])),
        'tc_back': ((x0, y0 - (t.thickness + g) * nf[1], z0 - (t.thickness + g) * nf[2]),
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
    """Write tine.stl and tine_cut.in into each deck's folder beside this script."""
    here = Path(__file__).resolve().parent
    for deck, tine in TINES.items():
        (here / deck / 'tine.stl').write_text(stl_text(tine))
        (here / deck / 'tine_cut.in').write_text(cut_region_text(tine))


if __name__ == '__main__':
    main()
