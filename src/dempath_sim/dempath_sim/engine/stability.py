"""Stability checks of the engine: the time step, overlaps and blow-ups, with the stable step.

An explicit DEM step is stable when dt is a fraction (`SimParams.rayleigh_safety`) of the
Rayleigh time step of the finest particle (see `timestep.py`). The engine stops an unstable
set-up with a `SimulationError` built here: a time step above the Rayleigh limit, an overlap
deeper than `SimParams.max_overlap_fraction` of a radius, or a particle moving more than a
given fraction of its radius per step (an energy blow-up). Each message names what went wrong
and gives the stable time step.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.timestep import rayleigh_time_step
from dempath_sim.errors import SimulationError


def stable_time_step(state: SimState, params: SimParams) -> float:
    """rayleigh_safety times the Rayleigh time step of the state's finest particle [s]."""
    return params.rayleigh_safety * rayleigh_time_step(state.radii, state.material, params)


def checked_time_step(state: SimState, params: SimParams) -> float:
    """The time step for `state`: params.dt, or `stable_time_step` when params.dt is None [s].

    Raises:
        SimulationError: params.dt exceeds the Rayleigh time step (message gives the limit).
    """
    dt_r = rayleigh_time_step(state.radii, state.material, params)
    if params.dt is None:
        return params.rayleigh_safety * dt_r
    if params.dt > dt_r:
        msg = (f'SimParams.dt = {params.dt:.3e} s exceeds the Rayleigh time step '
               f'{dt_r:.3e} s of the finest particle: unstable; stable dt <= '
               f'{dt_r:.3e} s (recommended {params.rayleigh_safety * dt_r:.3e} s)')
        raise SimulationError(msg)
    return params.dt


def check_overlaps(state: SimState, worst: NDArray[np.float64], n_walls: int,
                   params: SimParams, dt: float) -> None:
    """Stop a force pass whose deepest overlap exceeds max_overlap_fraction of a radius.

    Args:
        state, worst, n_walls, params, dt: As for `overlap_error`.

    Raises:
        SimulationError: The deepest overlap exceeds params.max_overlap_fraction of a radius.
    """
    deepest = worst[0, 0] if worst.shape[0] == 1 else worst[:, 0].max()  # one chunk: no reduction
    if deepest > params.max_overlap_fraction:
        raise overlap_error(state, worst, n_walls, params, dt)


def overlap_error(state: SimState, worst: NDArray[np.float64], n_walls: int,
                  params: SimParams, dt: float) -> SimulationError:
    """The error for the deepest overlap of a force pass.

    Args:
        state: The state the forces were computed for.
        worst: (n_chunks, 4) per chunk: overlap / radius, particle index, other (particle index
            >= 0; -1 - plane index for a plane; below -n_walls the tool), slot overflows.
        n_walls: Number of plane walls.
        params: The parameters (max_overlap_fraction, time-step settings).
        dt: The time step in use [s].
    """
    c = int(np.argmax(worst[:, 0]))
    ratio, i, other = worst[c, :3]
    what = (f'particle {state.ids[int(other)]}' if other >= 0 else
            f'plane {int(-1 - other)}' if -1 - other < n_walls else 'the tool')
    msg = (f'overlap of {100 * ratio:.1f}% of the radius between particle '
           f'{state.ids[int(i)]} and {what} at t = {state.time:.6f} s exceeds '
           f'SimParams.max_overlap_fraction = {params.max_overlap_fraction}: the '
           f'contacts are too soft or the time step too large (dt = {dt:.3e} s, '
           f'stable dt <= {stable_time_step(state, params):.3e} s)')
    return SimulationError(msg)


def check_drift(state: SimState, stats: NDArray[np.float64], max_courant: float,
                params: SimParams, dt: float) -> tuple[float, int]:
    """Reduce the per-chunk statistics of a drift; raises on an energy blow-up.

    Args:
        state: The state after the drift.
        stats: (n_chunks, 4) per chunk: largest squared displacement since the list build
            [m^2], largest |v| dt / r, particles out of the domain, non-finite velocities.
        max_courant: Largest |v| dt / r allowed.
        params: The parameters (time-step settings).
        dt: The time step in use [s].

    Returns:
        (largest displacement since the list build [m], particles out of the domain).

    Raises:
        SimulationError: Non-finite velocities or |v| dt / r > max_courant.
    """
    top = stats.max(axis=0) if stats.shape[0] > 1 else stats[0]
    courant = float(top[1])
    if top[3] > 0 or courant > max_courant:
        raise blowup_error(state, courant, int(stats[:, 3].sum()), params, dt)
    n_out = int(stats[:, 2].sum()) if top[2] > 0 else 0
    return math.sqrt(float(top[0])), n_out


def blowup_error(state: SimState, courant: float, n_nonfinite: int, params: SimParams,
                 dt: float) -> SimulationError:
    """The error for an energy blow-up: a particle moving `courant` radii in one step.

    Args:
        state: The state after the drift.
        courant: Largest |v| dt / r over the particles.
        n_nonfinite: Particles with non-finite velocities.
        params: The parameters (time-step settings).
        dt: The time step in use [s].
    """
    msg = (f'energy blow-up at t = {state.time:.6f} s: a particle moves '
           f'{courant:.2f} radii per step (non-finite: {n_nonfinite}); '
           f'dt = {dt:.3e} s, stable dt <= {stable_time_step(state, params):.3e} s')
    return SimulationError(msg)
