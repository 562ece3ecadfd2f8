"""Which model particles stand for a measured marker: the paper's Cube candidates.

The model's counterparts of a marker are the library particles whose start lies in a cube (the
scene's ``markers.cube_size_m``) centred on the marker's measured start (Kure & Kuretova 2025,
the Cube candidates), for any marker layout. A cube holding fewer than ``MIN_CUBE_MEMBERS``
particles is grown; when even the grown cube is empty (the model's bed lies elsewhere, e.g. a
lower surface) the nearest particles are taken. Used by the statistics, the paper's Table 7 and
the packed libraries alike, so all of them find the very same counterparts.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.records import F64

MIN_CUBE_MEMBERS = 3  # fewer model particles in a cube: the cube is grown
CUBE_GROWTH = (1.0, 1.5, 2.0)  # factors tried on the cube size
NEAREST_FALLBACK = 8  # particles taken when even the grown cube is empty


def cube_members(start: F64, marker_starts: F64, cube: tuple[float, float, float],
                 ) -> list[NDArray[np.intp]]:
    """Indices of the particles whose start lies in the cube around each marker start."""
    half = np.asarray(cube) / 2.0
    finite = np.flatnonzero(np.isfinite(start).all(1))
    out = []
    for p in marker_starts:
        for factor in CUBE_GROWTH:
            inside = np.flatnonzero(np.all(np.abs(start - p) <= half * factor, axis=1))
            if len(inside) >= MIN_CUBE_MEMBERS:
                break
        else:  # the model's bed lies elsewhere (e.g. a lower surface): the nearest particles
            dist = np.linalg.norm(start[finite] - p, axis=1)
            inside = finite[np.argsort(dist)[:NEAREST_FALLBACK]]
        out.append(inside)
    return out
