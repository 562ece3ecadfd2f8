"""The paper's soft sand (Table 6) against steel and jittered lattice beds of it, shared by the
engine tests of the spring rows and the kept list (import it relatively)."""

from __future__ import annotations

import numpy as np

from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState

RADIUS = 2.0e-3  # m


def sand_params(forms: str = 'dempath') -> SimParams:
    """Sand (E 1.7 MPa, e 0.3, mu_s 0.71, mu_d 0.59, mu_r 0.26) and steel walls / tool."""
    return SimParams((Material('sand', 2650.0, 1.7e6, 0.25),
                      Material('steel', 7800.0, 2.1e11, 0.3)),
                     {(0, 0): Interaction(0.3, 0.71, 0.59, rolling_resistance=0.26),
                      (0, 1): Interaction(0.3, 0.4, 0.3, rolling_resistance=0.26)},
                     contact_forms=forms)


def lattice_centres(lo: tuple[float, float, float], hi: tuple[float, float, float],
                    layers: int, spacing: float, jitter: float, seed: int) -> np.ndarray:
    """(n, 3) centres [m] on a lattice of ``spacing`` radii in the bin [lo, hi] (``layers``
    from the floor), each moved by up to ``jitter`` radii."""
    rng = np.random.default_rng(seed)
    step = spacing * RADIUS
    margin = 1.05 * RADIUS
    xs = np.arange(lo[0] + margin, hi[0] - RADIUS, step)
    ys = margin + step * np.arange(layers)
    zs = np.arange(lo[2] + margin, hi[2] - RADIUS, step)
    pos = np.stack(np.meshgrid(xs, ys, zs, indexing='ij'), axis=-1).reshape(-1, 3)
    return pos + rng.uniform(-jitter, jitter, size=pos.shape) * RADIUS


def lattice_bed(params: SimParams, centres: np.ndarray,
                velocities: np.ndarray | None = None) -> SimState:
    """Sand grains of RADIUS at ``centres`` (n, 3) [m]."""
    return SimState.from_spheres(centres, RADIUS, 0, params, velocities=velocities)
