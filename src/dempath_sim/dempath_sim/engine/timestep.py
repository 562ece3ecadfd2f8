"""Stable time steps: the Rayleigh criterion and the Hertz contact time.

Rayleigh time step of a sphere (Li et al., Powder Technol. 160 (2005) 219; as in LIGGGHTS and
Rocky)::

    dt_R = pi r sqrt(rho / G) / (0.1631 nu + 0.8766),

the time for a Rayleigh wave to cross the particle; explicit DEM runs at a fraction of the
smallest dt_R (typically 0.1-0.3). Hertz contact duration of a normal elastic impact at speed v
(Johnson 1985, 11.1)::

    t_c = 2.868 (m*^2 / (R* E*^2 v))^(1/5).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine.params import SimParams

HERTZ_DURATION_FACTOR = 2.8682  # 2 * integral, Johnson (1985) eq. 11.24


def rayleigh_time_step(radii: NDArray[np.float64], material: NDArray[np.int32],
                       params: SimParams) -> float:
    """Smallest Rayleigh time step over the particles [s] (inf when there are none)."""
    if len(radii) == 0:
        return math.inf
    best = math.inf
    for index in np.unique(material):
        mat = params.materials[int(index)]
        r_min = float(radii[material == index].min())
        dt = math.pi * r_min * math.sqrt(mat.density / mat.shear_modulus) / (
            0.1631 * mat.poisson_ratio + 0.8766)
        best = min(best, dt)
    return best


def hertz_contact_time(m_eff: float, r_eff: float, e_star: float, speed: float) -> float:
    """Duration of an elastic Hertzian impact at relative normal speed `speed` [s]."""
    return float(HERTZ_DURATION_FACTOR * (m_eff ** 2 / (r_eff * e_star ** 2 * speed)) ** 0.2)
