"""Results of a simulation run: tracked particle trajectories, tool pose and force, snapshots.

:class:`Recorder` is the streaming side (one call per output time, as the node uses it) and
:class:`SimResult` the batch record that ``run_scene`` returns; CSV export writes the model shape
``t,id,marker,x,y,z`` and the measured-trajectory shape ``t,marker,x,y,z`` (metres, seconds) that
dempath_compare reads. Units SI, world frame of the paper (X lateral, Y up, Z travel).
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath.errors import OutputError
from dempath_sim.runs.markers import ROLE_CANDIDATE, ROLE_MARKER

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class SimResult:
    """Trajectories of the tracked particles of one run (markers first, then candidates).

    Attributes:
        times: (nt,) output times [s] since the tool started.
        ids: (n,) stable particle ids.
        roles: (n,) uint8 ROLE_MARKER / ROLE_CANDIDATE.
        marker_ids: (n,) marker number each particle stands for or is a candidate of.
        radii: (n,) radii [m].
        positions: (nt, n, 3) positions [m]; NaN after a particle left the domain.
        velocities: (nt, n, 3) velocities [m/s]; NaN likewise.
        tool_position: (nt, 3) tool reference point (tip) [m].
        tool_force: (nt, 3) force of the particles on the tool [N].
        tool_torque: (nt, 3) torque on the tool about its reference point [N m].
        snapshot_times: (ns,) times of the full-bed snapshots [s].
        snapshot_ids: (N,) ids of every bed particle at the start.
        snapshot_positions: (ns, N, 3) float32 positions [m]; NaN when removed.
        snapshot_radii: (N,) radii [m] of the bed particles (empty for a result written
            before they were recorded, or by a backend without snapshots).
        meta: Scene name, seed, effects, fill report, timings (JSON-serialisable).
    """

    times: F64
    ids: NDArray[np.int64]
    roles: NDArray[np.uint8]
    marker_ids: NDArray[np.int32]
    radii: F64
    positions: F64
    velocities: F64
    tool_position: F64
    tool_force: F64
    tool_torque: F64
    snapshot_times: F64 = field(default_factory=lambda: np.zeros(0))
    snapshot_ids: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    snapshot_positions: NDArray[np.float32] = field(
        default_factory=lambda: np.zeros((0, 0, 3), np.float32))
    snapshot_radii: F64 = field(default_factory=lambda: np.zeros(0))
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def marker_numbers(self) -> NDArray[np.int32]:
        """Marker numbers present, ascending."""
        return np.asarray(np.unique(self.marker_ids[self.roles == ROLE_MARKER]), np.int32)

    def marker_trajectory(self, number: int) -> F64:
        """(nt, 3) positions [m] of the particle that stands for marker ``number``."""
        hit = np.flatnonzero((self.roles == ROLE_MARKER) & (self.marker_ids == number))
        if len(hit) != 1:
            msg = f'SimResult: no marker number {number!r}; have {self.marker_numbers.tolist()}'
            raise KeyError(msg)
        return self.positions[:, hit[0]]

    def candidate_ids(self, number: int) -> NDArray[np.int64]:
        """Ids of the candidates of marker ``number``."""
        return np.asarray(self.ids[(self.roles == ROLE_CANDIDATE) & (self.marker_ids == number)],
                          np.int64)

    def draft_force(self) -> F64:
        """(nt,) resistance against travel, -F_z [N]."""
        return -self.tool_force[:, 2]

    def save_npz(self, path: str | Path) -> None:
        """Write every array and the JSON meta to one compressed .npz."""
        arrays = {k: getattr(self, k) for k in _ARRAYS}
        try:
            np.savez_compressed(path, meta=np.array(json.dumps(self.meta)), **arrays)
        except OSError as err:
            raise OutputError(f'{path}: cannot write result ({err.strerror})') from err

    @classmethod
    def load_npz(cls, path: str | Path) -> SimResult:
        """Read a result written by :meth:`save_npz`."""
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in _ARRAYS if k in data.files or k not in _OPTIONAL}
            meta = json.loads(str(data['meta']))
        return cls(**arrays, meta=meta)

    def write_model_csv(self, path: str | Path, roles: tuple[int, ...] = (0, 1)) -> None:
        """CSV ``t,id,marker,x,y,z`` of the tracked particles with the given roles (NaN rows
        skipped); ``marker`` is the marker a particle stands for or is a Cube candidate of, so
        that a comparison ranks each marker's own candidates (the paper's N best of the cube),
        not one particle per marker."""
        cols = np.flatnonzero(np.isin(self.roles, roles))
        rows = ((t, int(self.ids[c]), int(self.marker_ids[c]), *self.positions[i, c])
                for i, t in enumerate(self.times) for c in cols)
        _write_csv(path, ('t', 'id', 'marker', 'x', 'y', 'z'), rows)

    def write_marker_csv(self, path: str | Path) -> None:
        """CSV ``t,marker,x,y,z`` of the marker particles, the measured-trajectory shape."""
        cols = np.flatnonzero(self.roles == ROLE_MARKER)
        rows = ((t, int(self.marker_ids[c]), *self.positions[i, c])
                for i, t in enumerate(self.times) for c in cols)
        _write_csv(path, ('t', 'marker', 'x', 'y', 'z'), rows)

    def write_tool_csv(self, path: str | Path) -> None:
        """CSV ``t,x,y,z,fx,fy,fz,tx,ty,tz`` of the tool pose [m], force [N] and torque [N m]."""
        rows = (
            (t, *self.tool_position[i], *self.tool_force[i], *self.tool_torque[i])
            for i, t in enumerate(self.times))
        _write_csv(path, ('t', 'x', 'y', 'z', 'fx', 'fy', 'fz', 'tx', 'ty', 'tz'), rows)


_ARRAYS = ('times', 'ids', 'roles', 'marker_ids', 'radii', 'positions', 'velocities',
           'tool_position', 'tool_force', 'tool_torque', 'snapshot_times', 'snapshot_ids',
           'snapshot_positions', 'snapshot_radii')
_OPTIONAL = ('snapshot_radii',)  # absent from results written before it was recorded


def _write_csv(path: str | Path, header: tuple[str, ...], rows: Any) -> None:
    try:
        with Path(path).open('w', newline='', encoding='utf-8') as f:
            writer = csv.writer(f)
            writer.writerow(header)
            for row in rows:
                if all(np.isfinite(v) for v in row):
                    writer.writerow([f'{v:.6g}' if isinstance(v, float) else v for v in row])
    except OSError as err:
        raise OutputError(f'{path}: cannot write CSV ({err.strerror})') from err


class Recorder:
    """Collects tracked particles, tool pose and force at output times, and bed snapshots.

    Args:
        ids: (n,) tracked particle ids; roles, marker_ids and radii alike (n,).
        bed_ids: (N,) ids of every particle for the snapshots.
        bed_radii: (N,) their radii [m] (for VTK output); empty when unknown.
    """

    def __init__(self, ids: NDArray[np.int64], roles: NDArray[np.uint8],
                 marker_ids: NDArray[np.int32], radii: F64, bed_ids: NDArray[np.int64],
                 bed_radii: F64 | None = None) -> None:
        self.ids, self.roles, self.marker_ids, self.radii = ids, roles, marker_ids, radii
        self.bed_ids = bed_ids
        self.bed_radii = np.zeros(0) if bed_radii is None else np.asarray(bed_radii, float)
        self.frames: list[tuple[float, F64, F64, F64, F64, F64]] = []
        self.snapshots: list[tuple[float, NDArray[np.float32]]] = []

    @staticmethod
    def _gather(state_ids: NDArray[np.int64], values: F64, wanted: NDArray[np.int64]) -> F64:
        """Rows of ``values`` for ``wanted`` ids; NaN for ids no longer present."""
        order = np.argsort(state_ids)
        pos = np.searchsorted(state_ids, wanted, sorter=order)
        pos = np.clip(pos, 0, max(len(order) - 1, 0))
        idx = order[pos] if len(order) else pos
        found = (state_ids[idx] == wanted) if len(order) else np.zeros(len(wanted), bool)
        out = np.full((len(wanted), 3), np.nan)
        out[found] = values[idx[found]]
        return out

    def record(self, t: float, state_ids: NDArray[np.int64], positions: F64, velocities: F64,
               tool_position: F64, tool_force: F64, tool_torque: F64) -> tuple[F64, F64]:
        """Store one output frame; return the tracked (n, 3) positions and velocities."""
        pos = self._gather(state_ids, positions, self.ids)
        vel = self._gather(state_ids, velocities, self.ids)
        self.frames.append((t, pos, vel, np.array(tool_position, float),
                            np.array(tool_force, float), np.array(tool_torque, float)))
        return pos, vel

    def snapshot(self, t: float, state_ids: NDArray[np.int64], positions: F64) -> None:
        """Store positions of the whole bed (float32)."""
        self.snapshots.append((t, self._gather(state_ids, positions, self.bed_ids)
                               .astype(np.float32)))

    def result(self, meta: dict[str, Any]) -> SimResult:
        """The recorded frames as a SimResult."""
        n, nt = len(self.ids), len(self.frames)

        def stack(k: int, shape: tuple[int, ...]) -> F64:
            return np.array([f[k] for f in self.frames], dtype=np.float64).reshape(shape)

        snaps = (np.array([s[1] for s in self.snapshots]) if self.snapshots
                 else np.zeros((0, len(self.bed_ids), 3), np.float32))
        return SimResult(
            times=np.array([f[0] for f in self.frames], dtype=np.float64), ids=self.ids,
            roles=self.roles, marker_ids=self.marker_ids, radii=self.radii,
            positions=stack(1, (nt, n, 3)), velocities=stack(2, (nt, n, 3)),
            tool_position=stack(3, (nt, 3)), tool_force=stack(4, (nt, 3)),
            tool_torque=stack(5, (nt, 3)),
            snapshot_times=np.array([s[0] for s in self.snapshots], dtype=np.float64),
            snapshot_ids=self.bed_ids, snapshot_positions=snaps, snapshot_radii=self.bed_radii,
            meta=meta)
