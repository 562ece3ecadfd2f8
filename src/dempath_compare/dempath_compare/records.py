"""Trajectory records: one raw track per marker or particle, and fixed-shape padded sets.

A :class:`Track` is what a loader produces (any length, maybe unsorted or broken). A
:class:`TrajectorySet` is the fixed-shape form the scoring works on: ``(n, T)`` times and
``(n, T, 3)`` positions padded with NaN, with a validity mask and a problem string per trajectory.
Positions are in the paper's world frame: X lateral, Y vertical up, Z direction of tool travel [m].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

MEASURED = 'measured'
MODEL = 'model'


class Track(NamedTuple):
    """One trajectory as loaded.

    Attributes:
        label: unique name, e.g. ``experiment_1ms/marker9`` or ``run3/541240``.
        group: experiment or run it belongs to (file stem, bag run id), e.g. ``experiment_1ms``.
        ident: marker number (measured) or particle id (model).
        marker_id: marker this trajectory is or is a candidate of; 0 when unknown.
        times: (k,) s.
        positions: (k, 3) m.
        problem: why it cannot be scored; empty when fine.
        note: warning that does not stop scoring (e.g. NaN samples dropped).
        speed_m_s: tool speed of the experiment or run [m/s]; NaN when unknown.
        run_id: model run (or experiment) id; the group name when nothing else is known.
        seed: packing seed of a model run; -1 when unknown.
        scene_key: the run's scene set-up key (``dempath_sim.runs.identity``); '' when unknown.
        physics_key: the run's physics key; '' when unknown.

    The loaders fill the last five (:mod:`dempath_compare.runinfo` says from what).
    """

    label: str
    group: str
    ident: int
    marker_id: int
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    problem: str = ''
    note: str = ''
    speed_m_s: float = math.nan
    run_id: str = ''
    seed: int = -1
    scene_key: str = ''
    physics_key: str = ''


@dataclass(frozen=True)
class TrajectorySet:
    """Fixed-shape trajectories, NaN-padded after each one's ``lengths[i]`` valid samples.

    Attributes:
        labels: (n,) unique names.
        groups: (n,) experiment / run names.
        idents: (n,) marker numbers or particle ids.
        marker_ids: (n,) associated marker (0: none).
        times: (n, T) s, NaN padded.
        positions: (n, T, 3) m, NaN padded.
        lengths: (n,) valid samples per trajectory (0 for a trajectory with a problem).
        problems: (n,) problem per trajectory, empty when it can be scored.
        notes: (n,) warnings per trajectory.
        origins: (n, 3) m, first position before the shift to the origin (NaN if unknown).
        speeds: (n,) tool speed [m/s] of each trajectory's experiment or run (NaN: unknown).
        run_ids: (n,) run (or experiment) ids.
        seeds: (n,) packing seeds (-1: unknown).
        scene_keys: (n,) scene set-up keys ('': unknown).
        physics_keys: (n,) physics keys ('': unknown).
    """

    labels: tuple[str, ...]
    groups: tuple[str, ...]
    idents: NDArray[np.int64]
    marker_ids: NDArray[np.int64]
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    lengths: NDArray[np.int64]
    problems: tuple[str, ...]
    notes: tuple[str, ...]
    origins: NDArray[np.float64]
    speeds: NDArray[np.float64]
    run_ids: tuple[str, ...]
    seeds: NDArray[np.int64]
    scene_keys: tuple[str, ...]
    physics_keys: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.labels)

    @property
    def mask(self) -> NDArray[np.bool_]:
        """(n, T) True where a sample is valid."""
        return np.arange(self.times.shape[1])[None, :] < self.lengths[:, None]

    @property
    def valid(self) -> NDArray[np.bool_]:
        """(n,) True for trajectories that can be scored."""
        return np.array([p == '' for p in self.problems], dtype=bool) & (self.lengths > 0)

    def track(self, i: int) -> Track:
        """Trajectory ``i`` as a :class:`Track` (valid samples only)."""
        k = int(self.lengths[i])
        return Track(self.labels[i], self.groups[i], int(self.idents[i]), int(self.marker_ids[i]),
                     self.times[i, :k].copy(), self.positions[i, :k].copy(), self.problems[i],
                     self.notes[i], float(self.speeds[i]), self.run_ids[i], int(self.seeds[i]),
                     self.scene_keys[i], self.physics_keys[i])

    def positions_list(self, index: Sequence[int] | NDArray[np.int64]
                       ) -> list[NDArray[np.float64]]:
        """Valid (k, 3) m position arrays of the trajectories in ``index`` (C-contiguous)."""
        return [np.ascontiguousarray(self.positions[i, : self.lengths[i]]) for i in index]

    def with_problem(self, i: int, problem: str) -> TrajectorySet:
        """A copy where trajectory ``i`` is marked unusable with ``problem``."""
        problems = list(self.problems)
        problems[i] = problem
        lengths = self.lengths.copy()
        lengths[i] = 0
        return replace(self, problems=tuple(problems), lengths=lengths)


def pack_tracks(tracks: Sequence[Track], shift_to_origin: bool = False) -> TrajectorySet:
    """Pad tracks into a :class:`TrajectorySet`; tracks with a problem get length 0.

    Args:
        tracks: loaded or preprocessed tracks.
        shift_to_origin: subtract each track's first position so that it starts at (0, 0, 0)
            (paper sec. 2.5); the subtracted point is kept in ``origins``.

    Returns:
        The fixed-shape set, ``T`` = longest usable track (at least 1).
    """
    usable = [len(t.times) if not t.problem else 0 for t in tracks]
    n, width = len(tracks), max([1, *usable])
    times = np.full((n, width), np.nan)
    positions = np.full((n, width, 3), np.nan)
    origins = np.full((n, 3), np.nan)
    for i, (track, k) in enumerate(zip(tracks, usable, strict=True)):
        times[i, :k] = track.times[:k]
        positions[i, :k] = track.positions[:k]
        if len(track.positions) and np.all(np.isfinite(track.positions[0])):
            origins[i] = track.positions[0]
            if shift_to_origin:
                positions[i, :k] -= origins[i]
    return TrajectorySet(
        labels=tuple(t.label for t in tracks), groups=tuple(t.group for t in tracks),
        idents=np.array([t.ident for t in tracks], dtype=np.int64).reshape(n),
        marker_ids=np.array([t.marker_id for t in tracks], dtype=np.int64).reshape(n),
        times=times, positions=positions, lengths=np.array(usable, dtype=np.int64).reshape(n),
        problems=tuple(t.problem for t in tracks), notes=tuple(t.note for t in tracks),
        origins=origins, speeds=np.array([t.speed_m_s for t in tracks], np.float64).reshape(n),
        run_ids=tuple(t.run_id for t in tracks),
        seeds=np.array([t.seed for t in tracks], dtype=np.int64).reshape(n),
        scene_keys=tuple(t.scene_key for t in tracks),
        physics_keys=tuple(t.physics_key for t in tracks))


def concat_sets(sets: Sequence[TrajectorySet]) -> TrajectorySet:
    """Stack several sets (e.g. many model runs) into one, padding to the longest."""
    if not sets:
        return pack_tracks([])
    width = max(s.times.shape[1] for s in sets)

    def pad(a: NDArray[np.float64]) -> NDArray[np.float64]:
        extra = [(0, 0), (0, width - a.shape[1])] + [(0, 0)] * (a.ndim - 2)
        return np.pad(a, extra, constant_values=np.nan)

    return TrajectorySet(
        labels=tuple(x for s in sets for x in s.labels),
        groups=tuple(x for s in sets for x in s.groups),
        idents=np.concatenate([s.idents for s in sets]),
        marker_ids=np.concatenate([s.marker_ids for s in sets]),
        times=np.concatenate([pad(s.times) for s in sets]),
        positions=np.concatenate([pad(s.positions) for s in sets]),
        lengths=np.concatenate([s.lengths for s in sets]),
        problems=tuple(x for s in sets for x in s.problems),
        notes=tuple(x for s in sets for x in s.notes),
        origins=np.concatenate([s.origins for s in sets]),
        speeds=np.concatenate([s.speeds for s in sets]),
        run_ids=tuple(x for s in sets for x in s.run_ids),
        seeds=np.concatenate([s.seeds for s in sets]),
        scene_keys=tuple(x for s in sets for x in s.scene_keys),
        physics_keys=tuple(x for s in sets for x in s.physics_keys))
