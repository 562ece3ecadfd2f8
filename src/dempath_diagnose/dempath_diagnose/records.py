"""Records of the diagnosis: a model pass as kept in the library, and a measured case.

Frame: the scene's (paper's) frame, X lateral, Y up, Z tool travel, metres and seconds, t = 0
when the tool starts to move.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.errors import LibraryError

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class PassRecord:
    """The particles near the surface of one model pass, subsampled in time, and the tool.

    Attributes:
        times: (nt,) frame times [s].
        ids: (n,) stable particle ids.
        positions: (nt, n, 3) float32 positions [m]; NaN once a particle left the domain.
        tool_position: (nt, 3) tool reference point at the frame times [m].
        force_times: (nf,) times of the force samples [s] (every output interval).
        tool_force: (nf, 3) force of the particles on the tool [N] (draft = -Fz).
        meta: Seed, overrides, surface height, timings (JSON-serialisable).
    """

    times: F64
    ids: NDArray[np.int64]
    positions: NDArray[np.float32]
    tool_position: F64
    force_times: F64
    tool_force: F64
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def start(self) -> F64:
        """(n, 3) start positions [m]."""
        return np.asarray(self.positions[0], np.float64)

    def save(self, path: Path) -> None:
        """Write atomically to ``path`` (.npz): a crash never leaves half a record."""
        tmp = path.with_name(path.name + '.tmp.npz')
        np.savez_compressed(tmp, times=self.times, ids=self.ids, positions=self.positions,
                            tool_position=self.tool_position, force_times=self.force_times,
                            tool_force=self.tool_force, meta=np.array(json.dumps(self.meta)))
        tmp.replace(path)

    @staticmethod
    def read_meta(path: Path) -> dict[str, Any]:
        """Only the meta of a stored record (cheap: the arrays are not read); {} if unreadable."""
        try:
            with np.load(path, allow_pickle=False) as data:
                meta = json.loads(str(data['meta']))
        except (OSError, KeyError, ValueError):
            return {}
        return meta if isinstance(meta, dict) else {}

    @classmethod
    def load(cls, path: Path) -> PassRecord:
        """Read a record written by :meth:`save`; LibraryError if unreadable."""
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in ('times', 'ids', 'positions', 'tool_position',
                                               'force_times', 'tool_force')}
                meta = json.loads(str(data['meta']))
        except (OSError, KeyError, ValueError) as err:
            msg = f'{path}: unreadable library run ({err})'
            raise LibraryError(msg) from err
        return cls(**arrays, meta=meta)


@dataclass(frozen=True)
class Measurement:
    """A measured pass on a common time base, ready for the statistics.

    Attributes:
        markers: (m,) marker numbers.
        times: (nt,) common times [s].
        positions: (nt, m, 3) positions in the scene frame [m]; NaN where a marker is unseen.
        force_times: (nf,) times of the force samples [s] (empty without a force).
        force: (nf, 3) force of the particles on the tool [N] (empty without a force).
        problems: Per-marker faults found on loading, ``{marker: text}`` (those are left out).
        time_origin: Where t = 0 came from when it was not the input's own (a bag's stamps).
    """

    markers: NDArray[np.int64]
    times: F64
    positions: F64
    force_times: F64 = field(default_factory=lambda: np.zeros(0))
    force: F64 = field(default_factory=lambda: np.zeros((0, 3)))
    problems: dict[int, str] = field(default_factory=dict)
    time_origin: str = ''

    @property
    def start(self) -> F64:
        """(m, 3) start positions [m] (first finite sample of each marker)."""
        out = np.full((len(self.markers), 3), np.nan)
        for j in range(len(self.markers)):
            ok = np.flatnonzero(np.isfinite(self.positions[:, j, 0]))
            if len(ok):
                out[j] = self.positions[ok[0], j]
        return out

    @property
    def has_force(self) -> bool:
        """Whether a force was measured."""
        return len(self.force_times) > 0

    def split(self, held_out: tuple[int, ...]) -> tuple[Measurement, Measurement]:
        """(this pass without the markers ``held_out``, those markers alone without the force):
        the markers a fit uses and the ones it is checked on."""
        held = np.isin(self.markers, held_out)
        fit = replace(self, markers=self.markers[~held], positions=self.positions[:, ~held])
        rest = Measurement(self.markers[held], self.times, self.positions[:, held])
        return fit, rest
