# mypy: disable-error-code="no-untyped-def"
"""Simplified JKR cohesion (SJKR): an attractive normal force proportional to the contact area.

F_c = k_c A, with k_c the cohesion energy density [J/m^3] and A the area of the overlap's contact
circle (LIGGGHTS `cohesion sjkr`; Johnson, Kendall & Roberts, Proc. R. Soc. A 324 (1971) 301).
Acts only while the bodies overlap. For two spheres at centre distance d::

    A = pi a^2,  a^2 = (r_i + r_j - d)(d + r_i - r_j)(d - r_i + r_j)(d + r_i + r_j) / (4 d^2),

and for a sphere on a plane or triangle (r_j -> infinity) A = pi (2 r delta - delta^2).
"""

from __future__ import annotations

import math

from numba import njit


@njit(inline='always', fastmath=True, cache=True)
def sjkr_area_pair(d, r_i, r_j):  # pragma: no cover - compiled
    """Contact-circle area of two overlapping spheres at centre distance d [m^2]."""
    a2 = (r_i + r_j - d) * (d + r_i - r_j) * (d - r_i + r_j) * (d + r_i + r_j) / (4.0 * d * d)
    return math.pi * max(a2, 0.0)


@njit(inline='always', fastmath=True, cache=True)
def sjkr_area_wall(r, delta):  # pragma: no cover - compiled
    """Contact-circle area of a sphere of radius r overlapping a plane by delta [m^2]."""
    return math.pi * max(2.0 * r * delta - delta * delta, 0.0)
