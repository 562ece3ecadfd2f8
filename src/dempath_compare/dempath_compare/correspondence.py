"""Marker-to-particle correspondence by initial position: the paper's Cube region.

The paper exported from Ansys Rocky the particles starting in a region of 30 mm (X) x 20 mm (Y) x
10 mm (Z) around each marker, about 90 trajectories, to allow for uncertainty in the initial
placement of the markers (Kuře & Kuřetová 2025, sec. 3.7).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray


def cube_candidates(marker_starts: NDArray[np.float64], particle_starts: NDArray[np.float64],
                    size: Sequence[float] = (0.030, 0.020, 0.010)) -> NDArray[np.bool_]:
    """(n_markers, n_particles) True where a particle starts inside a marker's Cube region.

    Args:
        marker_starts: (n_markers, 3) m initial marker positions (NaN: no candidates).
        particle_starts: (n_particles, 3) m initial particle positions.
        size: Cube edge lengths along X, Y, Z [m], centred on the marker start.
    """
    half = np.asarray(size, dtype=np.float64) / 2.0
    offset = np.abs(particle_starts[None, :, :] - marker_starts[:, None, :])
    with np.errstate(invalid='ignore'):
        return np.asarray(np.all(offset <= half, axis=2))


def assign_markers(marker_ids: NDArray[np.int64], marker_starts: NDArray[np.float64],
                   particle_starts: NDArray[np.float64],
                   size: Sequence[float] = (0.030, 0.020, 0.010)) -> NDArray[np.int64]:
    """(n_particles,) marker whose Cube holds each particle start (nearest if several; 0: none)."""
    inside = cube_candidates(marker_starts, particle_starts, size)
    dist = np.linalg.norm(particle_starts[None, :, :] - marker_starts[:, None, :], axis=2)
    dist = np.where(inside, dist, np.inf)
    nearest = np.argmin(dist, axis=0)
    if len(marker_ids) == 0:
        return np.zeros(len(particle_starts), dtype=np.int64)
    found = np.isfinite(dist.min(axis=0))
    out = np.where(found, marker_ids[nearest], 0)
    return np.asarray(out, dtype=np.int64)
