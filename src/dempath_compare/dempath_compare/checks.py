"""Per-trajectory input checks: each problem is reported on its trajectory, never raised.

A trajectory with a problem is excluded from scoring and listed with the reason in every output;
the rest is still scored. Non-finite samples are dropped with a note (occlusion gaps are normal in
measured data); the trajectory is excluded only when too few samples remain.
"""

from __future__ import annotations

import logging

import numpy as np

from dempath_compare.config import CompareConfig
from dempath_compare.records import MEASURED, Track

log = logging.getLogger(__name__)


def check_track(track: Track, kind: str, config: CompareConfig) -> Track:
    """Validate one loaded track.

    Args:
        track: as loaded; ``times`` (k,) s, ``positions`` (k, 3) m.
        kind: ``MEASURED`` or ``MODEL``.
        config: comparison settings (``min_points``, ``mm_threshold``, ``marker_ids``).

    Returns:
        The track with non-finite samples dropped and ``problem`` / ``note`` filled in.
    """
    if track.problem:
        return track
    times = np.asarray(track.times, dtype=np.float64).reshape(-1)
    positions = np.asarray(track.positions, dtype=np.float64).reshape(len(times), 3)
    finite = np.isfinite(times) & np.all(np.isfinite(positions), axis=1)
    note = track.note
    if not finite.all():
        note = _join(note, f'dropped {int((~finite).sum())} non-finite (NaN) sample(s)')
        times, positions = times[finite], positions[finite]
    checked = track._replace(times=times, positions=positions, note=note)
    problem = _first_problem(checked, kind, config)
    if problem:
        log.info('%s: %s', track.label, problem)
    return checked._replace(problem=problem)


def _first_problem(track: Track, kind: str, config: CompareConfig) -> str:
    times, positions = track.times, track.positions
    known = set(config.marker_ids)
    marker = track.ident if kind == MEASURED else track.marker_id
    if (kind == MEASURED or marker != 0) and marker not in known:
        return (f'marker number {marker} does not exist '
                f'(known markers {min(known)}-{max(known)})')
    if len(times) < config.min_points:
        return f'only {len(times)} valid sample(s), need at least {config.min_points}'
    steps = np.diff(times)
    if np.any(steps == 0.0):
        at = float(times[1:][steps == 0.0][0])
        return f'duplicated time stamp t={at:.6g} s'
    if np.any(steps < 0.0):
        index = int(np.flatnonzero(steps < 0.0)[0]) + 1
        return f'time stamps not increasing (sample {index}, t={times[index]:.6g} s)'
    biggest = float(np.max(np.abs(positions)))
    if biggest > config.mm_threshold:
        return (f'coordinates up to {biggest:.4g} look like millimetres '
                f'(limit {config.mm_threshold:g} m); give metres')
    return ''


def _join(first: str, second: str) -> str:
    return f'{first}; {second}' if first else second
