"""Materials, parameters and meshes shared by the tool-mesh tests (import it relatively).

A 2 mm grain sphere against steel: the grain-steel pair has rolling resistance, so the mesh
tests cover the tangential and the rolling springs.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.walls import Plane

GRAIN = Material('grain', 2500.0, 5.0e7, 0.25)
STEEL = Material('steel', 7800.0, 2.1e11, 0.3)
RADIUS = 2.0e-3  # m, sphere radius
PARAMS = SimParams((GRAIN, STEEL), {(0, 0): Interaction(0.5, 0.5, 0.4),
                                    (0, 1): Interaction(0.5, 0.4, 0.3, rolling_resistance=0.1)})
FLOOR = (Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 1),)  # steel plane y = 0, the mesh's twin


def flat_patch(n: int, size: float) -> NDArray[np.float64]:
    """(2 n^2, 3, 3) triangles tiling the square [-size, size]^2 of the plane y = 0 [m]."""
    xs = np.linspace(-size, size, n + 1)
    tris = []
    for a in range(n):
        for b in range(n):
            p00 = [xs[a], 0.0, xs[b]]
            p10 = [xs[a + 1], 0.0, xs[b]]
            p01 = [xs[a], 0.0, xs[b + 1]]
            p11 = [xs[a + 1], 0.0, xs[b + 1]]
            tris += [[p00, p10, p11], [p00, p11, p01]]
    return np.array(tris)
