"""Marker particles and their candidates, chosen on the settled bed.

The paper's grid (Kuře & Kuřetová, Technologies 2025, 13, 570, Sec. 2.1): 3 x 5 contrasting
particles, 50 mm apart in X and Z, numbered 1-15 with 1-5 on the tool axis. Here row r holds
markers r * columns + 1 ... (r + 1) * columns in travel order (+Z), row 0 on the tool axis and
the other rows on one side (``MarkerSpec.side``). Each marker is the surface particle nearest its
grid point; its candidates are the particles whose centres lie in a box like the paper's Cube
tool (30 x 20 x 10 mm in X, Y, Z, about 90 particles of 4 mm) centred on the grid point in X and
Z and reaching down from the local surface. Particles are referred to by their stable ids.

Assumptions: the local surface height is the highest particle top within two diameters of the
grid point; a particle is on the surface when its top is within one diameter of that height
(``MarkerSpec.pick: exposed``, the default) or, with ``pick: top``, when its centre is within one
radius of the highest centre there (the hand-written LIGGGHTS decks' surface grains: they sit
about 2 mm higher on the raked-tine bin's 7-8 mm sand, and grains beside a tine move outward
less the deeper they sit, docs/liggghts.md).
A particle inside two cubes is a candidate of the lower-numbered marker only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dempath_sim.errors import SimulationError
from dempath_sim.scene.spec import MarkerSpec

ROLE_MARKER = 0  # dempath_msgs/ParticleStates ROLE_MARKER
ROLE_CANDIDATE = 1  # ROLE_CANDIDATE
ROLE_BED = 2  # ROLE_BED


class MarkerSelectionError(SimulationError):
    """No particle near a marker's grid point (the grid lies outside the bed)."""


@dataclass(frozen=True)
class MarkerSelection:
    """Markers and candidates picked on one packing.

    Attributes:
        numbers: (m,) marker numbers 1..rows*columns.
        particle_ids: (m,) stable id of each marker particle.
        grid_points: (m, 3) grid points at the local surface height [m].
        candidate_ids: (k,) stable ids of the candidates (marker particles excluded).
        candidate_markers: (k,) marker number each candidate belongs to.
    """

    numbers: NDArray[np.int32]
    particle_ids: NDArray[np.int64]
    grid_points: NDArray[np.float64]
    candidate_ids: NDArray[np.int64]
    candidate_markers: NDArray[np.int32]

    def tracked(self, candidates: bool = True) -> tuple[NDArray[np.int64], NDArray[np.uint8],
                                                        NDArray[np.int32]]:
        """Ids (n,), roles (n,) and marker numbers (n,): markers first, then candidates."""
        ids = [self.particle_ids]
        roles = [np.full(len(self.numbers), ROLE_MARKER, np.uint8)]
        marker = [self.numbers]
        if candidates:
            ids.append(self.candidate_ids)
            roles.append(np.full(len(self.candidate_ids), ROLE_CANDIDATE, np.uint8))
            marker.append(self.candidate_markers)
        return (np.concatenate(ids).astype(np.int64), np.concatenate(roles),
                np.concatenate(marker).astype(np.int32))

    def candidates_of(self, number: int) -> NDArray[np.int64]:
        """Ids of the candidates of marker ``number``."""
        return np.asarray(self.candidate_ids[self.candidate_markers == number], np.int64)


def grid_xz(spec: MarkerSpec) -> tuple[NDArray[np.int32], NDArray[np.float64]]:
    """Marker numbers (m,) and grid points (m, 2) as (x, z) [m], in numbering order."""
    rows, cols = np.meshgrid(np.arange(spec.rows), np.arange(spec.columns), indexing='ij')
    numbers = (rows * spec.columns + cols + 1).ravel().astype(np.int32)
    x = spec.x_m + rows.ravel() * spec.side * spec.spacing_x_m
    z = spec.first_z_m + cols.ravel() * spec.spacing_z_m
    return numbers, np.column_stack([x, z]).astype(np.float64)


def _pick_marker(positions: NDArray[np.float64], radii: NDArray[np.float64],
                 point: NDArray[np.float64], number: int, pick: str = 'exposed'
                 ) -> tuple[int, float]:
    """Index of the surface particle nearest ``point`` (x, z) by the rule ``pick`` and the
    local surface height."""
    d_xz = np.hypot(positions[:, 0] - point[0], positions[:, 2] - point[1])
    reach = 4.0 * float(np.median(radii))
    near = np.flatnonzero(d_xz < reach)
    if len(near) == 0:
        msg = f'marker {number}: no particle within {reach:.3g} m of grid point {point.tolist()}'
        raise MarkerSelectionError(msg)
    tops = positions[near, 1] + radii[near]
    surface = float(tops.max())
    if pick == 'top':
        centres = positions[near, 1]
        exposed = near[centres > centres.max() - float(np.median(radii))]
    else:
        exposed = near[tops > surface - 2.0 * radii[near]]
    return int(exposed[np.argmin(d_xz[exposed])]), surface


def select_markers(positions: NDArray[np.float64], radii: NDArray[np.float64],
                   ids: NDArray[np.int64], spec: MarkerSpec) -> MarkerSelection:
    """Pick marker particles and Cube candidates on a settled packing.

    Args:
        positions: (n, 3) particle centres [m].
        radii: (n,) radii [m].
        ids: (n,) stable particle ids.
        spec: The scene's marker grid and cube size.

    Returns:
        The selection, ordered by marker number.

    Raises:
        MarkerSelectionError: A grid point has no particle near it.
    """
    numbers, points = grid_xz(spec)
    chosen, grid, taken = [], [], np.zeros(len(ids), bool)
    cand_idx: list[NDArray[np.intp]] = []
    cand_num: list[NDArray[np.int32]] = []
    sx, sy, sz = spec.cube_size_m
    for number, point in zip(numbers, points, strict=True):
        index, surface = _pick_marker(positions, radii, point, int(number), spec.pick)
        chosen.append(index)
        grid.append((point[0], surface, point[1]))
        taken[index] = True
    for number, (gx, gy, gz) in zip(numbers, grid, strict=True):
        inside = ((np.abs(positions[:, 0] - gx) <= sx / 2)
                  & (np.abs(positions[:, 2] - gz) <= sz / 2)
                  & (positions[:, 1] <= gy) & (positions[:, 1] >= gy - sy) & ~taken)
        members = np.flatnonzero(inside)
        taken[members] = True
        cand_idx.append(members)
        cand_num.append(np.full(len(members), number, np.int32))
    cand = np.concatenate(cand_idx) if cand_idx else np.zeros(0, np.intp)
    return MarkerSelection(
        numbers=numbers, particle_ids=np.asarray(ids)[chosen].astype(np.int64),
        grid_points=np.array(grid, dtype=np.float64),
        candidate_ids=np.asarray(ids)[cand].astype(np.int64),
        candidate_markers=np.concatenate(cand_num) if cand_num else np.zeros(0, np.int32))
