"""Preprocessing of the paper (sec. 2.5): start of motion, optional end trimming, shift to origin.

Start of motion (paper eq. 1): with v_z the Z velocity (finite differences) and the rest phase the
first ``rest_samples`` samples, the motion starts at the first sample k whose forward velocity
v_z[k] = (z[k+1] - z[k]) / (t[k+1] - t[k]) exceeds

    v_thr = mean(v_z,rest) + sp * std(v_z,rest)        (std with ddof = 0)

and the trajectory is cut to start at sample k (the last position at rest). End trimming of
measured trajectories (the paper's user-defined option) cuts the trajectory at the first sample
whose Y lies more than ``trim_y_drop`` below the running maximum of Y.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from dempath_compare.checks import check_track
from dempath_compare.config import CompareConfig
from dempath_compare.records import MEASURED, MODEL, Track, TrajectorySet, pack_tracks


def motion_threshold(times: NDArray[np.float64], z: NDArray[np.float64], sp: float,
                     rest_samples: int) -> float:
    """v_thr = mean(v_z) + sp * std(v_z) over the rest phase [m/s] (paper eq. 1).

    Args:
        times: (k,) s, increasing.
        z: (k,) m, position along the tool travel.
        sp: sensitivity parameter (higher -> later detection).
        rest_samples: samples of the rest phase (their rest_samples - 1 velocities are used).
    """
    v_rest = np.diff(z[:rest_samples]) / np.diff(times[:rest_samples])
    return float(np.mean(v_rest) + sp * np.std(v_rest))


def motion_start_index(times: NDArray[np.float64], z: NDArray[np.float64], sp: float,
                       rest_samples: int) -> int | None:
    """First sample k whose forward Z velocity exceeds v_thr, or None when motion never starts."""
    if len(times) <= rest_samples:
        return None
    threshold = motion_threshold(times, z, sp, rest_samples)
    v_z = np.diff(z) / np.diff(times)
    above = np.flatnonzero(v_z > threshold)
    return int(above[0]) if len(above) else None


def trim_end_index(y: NDArray[np.float64], drop: float) -> int:
    """Samples to keep: up to (excluding) the first Y over ``drop`` [m] below its running max."""
    fallen = np.flatnonzero(y < np.maximum.accumulate(y) - drop)
    return int(fallen[0]) if len(fallen) else len(y)


def prepare_track(track: Track, kind: str, config: CompareConfig) -> Track:
    """Check, cut at the start of motion (model; measured if configured) and trim (measured)."""
    track = check_track(track, kind, config)
    if track.problem:
        return track
    times, positions, note = track.times, track.positions, track.note
    if kind == MODEL or config.detect_start_measured:
        start = motion_start_index(times, positions[:, 2], config.sp, config.rest_samples)
        if start is None:
            v_thr = (motion_threshold(times, positions[:, 2], config.sp, config.rest_samples)
                     if len(times) > config.rest_samples else float('nan'))
            problem = (f'no detectable start of motion (v_z never exceeds '
                       f'v_thr={v_thr:.4g} m/s, sp={config.sp:g})')
            return track._replace(problem=problem)
        times, positions = times[start:], positions[start:]
    if kind == MEASURED and config.trim_y_drop is not None:
        keep = trim_end_index(positions[:, 1], config.trim_y_drop)
        if keep < len(times):
            note = _join(note, f'trimmed at t={times[keep]:.4g} s (Y decreased)')
        times, positions = times[:keep], positions[:keep]
    if len(times) < config.min_points:
        problem = f'only {len(times)} sample(s) left after start/trim, need {config.min_points}'
        return track._replace(problem=problem)
    return track._replace(times=times, positions=positions, note=note)


def prepare_set(tracks: Sequence[Track], kind: str, config: CompareConfig) -> TrajectorySet:
    """Prepare every track and pack them, shifted to start at the origin (paper sec. 2.5)."""
    return pack_tracks([prepare_track(t, kind, config) for t in tracks], shift_to_origin=True)


def _join(first: str, second: str) -> str:
    return f'{first}; {second}' if first else second
