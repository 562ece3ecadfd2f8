"""Stability checks of the engine: what makes an explicit DEM run unstable, with what to change.

An explicit DEM step is stable when dt is a fraction (`SimParams.rayleigh_safety`) of the
Rayleigh time step of the finest particle (see `timestep.py`) and when every contact's own
oscillation is resolved: a Hertz contact stiffens as it is pressed (k ~ sqrt(delta)), so a deep
contact needs a shorter step than a light one (`contact_stable_step`). The engine stops a run
with a `SimulationError` built here when it is, or is about to become, unstable: a time step
above the Rayleigh limit; a contact the time step no longer resolves (`check_contacts`); a
particle moving more than half its radius per step or non-finite velocities (a blow-up); more
than 1 % of the particles leaving the domain (`lost_error`). An overlap alone is not
instability: soft sand (E = 1.7 MPa) overlaps by half a radius and more under a tool with every
contact resolved, so `SimParams.max_overlap_fraction` is only a geometric guard (a full radius
by default). Each message names what went wrong and the setting to change.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine.materials import pair_properties
from dempath_sim.engine.params import DEFAULT_MAX_OVERLAP_FRACTION, SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.timestep import rayleigh_time_step
from dempath_sim.engine.walls import Plane
from dempath_sim.errors import SimulationError

logger = logging.getLogger(__name__)


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
               f'{dt_r:.3e} s (recommended {params.rayleigh_safety * dt_r:.3e} s): lower '
               f'sim.time_step_s, or leave it unset to use sim.rayleigh_safety x the '
               f'Rayleigh step')
        raise SimulationError(msg)
    return params.dt


def contact_stable_step(params: SimParams, mat_i: int, mat_j: int, r_eff: float, m_eff: float,
                        delta: float) -> float:
    """Largest stable time step of one Hertz contact at overlap ``delta`` [s].

    The contact is a damped spring along its normal with the tangent stiffness
    k_n = dF_n / d delta = 2 E* sqrt(R* delta) and the mass m*. Velocity Verlet integrates a
    damped oscillator stably for omega dt <= 2 (sqrt(1 + zeta^2) - zeta), omega^2 = k_n / m*
    (the central-difference limit; Belytschko, Liu & Moran, Nonlinear Finite Elements, 2000,
    sec. 6.3), with the damping ratio zeta = sqrt(5/6) beta of the restitution dashpot. The
    normal motion is the one that blows up: the tangential-rotational motion of a contact is
    about 1.7 times faster, but its spring is capped by the Coulomb limit, so beyond its own
    step it jitters within the friction bound (the margin `rayleigh_safety` keeps).
    """
    props = pair_properties(params.materials[mat_i], params.materials[mat_j])
    k_n = 2.0 * props.effective_youngs * math.sqrt(max(r_eff * delta, 0.0))
    if k_n <= 0.0:
        return math.inf
    zeta = math.sqrt(5.0 / 6.0) * params.interaction(mat_i, mat_j).damping_beta
    return 2.0 * (math.sqrt(1.0 + zeta * zeta) - zeta) / math.sqrt(k_n / m_eff)


def _contact_of(state: SimState, row: NDArray[np.float64], walls: Sequence[Plane],
                tool_material: int) -> tuple[str, int, float, float]:
    """(what i touches, its material, R*, m*) of a chunk's deepest contact ``row``."""
    i, other = int(row[1]), int(row[2])
    r_i, m_i = float(state.radii[i]), float(state.masses[i])
    if other >= 0:
        r_j, m_j = float(state.radii[other]), float(state.masses[other])
        return (f'particle {state.ids[other]}', int(state.material[other]),
                r_i * r_j / (r_i + r_j), m_i * m_j / (m_i + m_j))
    if -1 - other < len(walls):
        return f'plane {-1 - other}', walls[-1 - other].material, r_i, m_i
    return 'the tool', tool_material, r_i, m_i


def check_contacts(state: SimState, worst: NDArray[np.float64], walls: Sequence[Plane],
                   tool_material: int, params: SimParams, dt: float,
                   screen: float = 0.0) -> None:
    """Stop a force pass whose deepest contact is unstable or beyond the overlap guard.

    Each thread chunk's deepest contact (overlap / radius, particle, other) is checked: its
    stable step (`contact_stable_step`) must not be below dt, and its overlap must not exceed
    ``params.max_overlap_fraction`` (a geometric guard, a full radius by default). Soft grains
    legitimately overlap by half a radius and more under a tool; what makes a run unstable is a
    contact that the time step no longer resolves.

    Args:
        state: The state the forces were computed for.
        worst: (n_chunks, 4) per chunk: overlap / radius, particle index, other (particle index
            >= 0; -1 - plane index for a plane; below -n_walls the tool), slot overflows.
        walls: The engine's plane walls.
        tool_material: Material index of the tool.
        params: The parameters (max_overlap_fraction, time-step settings).
        dt: The time step in use [s].
        screen: Overlap / radius below which no contact can be unstable at dt (see
            `unstable_overlap`): the exact check is skipped (speed).

    Raises:
        SimulationError: An unstable contact or an overlap beyond the guard, with what to change.
    """
    deepest = worst[0, 0] if worst.shape[0] == 1 else worst[:, 0].max()  # one chunk: no reduction
    if deepest <= screen and deepest <= params.max_overlap_fraction:
        return
    for row in worst:
        if row[0] <= 0.0:
            continue
        what, mat_j, r_eff, m_eff = _contact_of(state, row, walls, tool_material)
        i = int(row[1])
        limit = contact_stable_step(params, int(state.material[i]), mat_j, r_eff, m_eff,
                                    float(row[0]) * float(state.radii[i]))
        where = (f'between particle {state.ids[i]} and {what} at t = {state.time:.6f} s '
                 f'(overlap {100 * row[0]:.1f}% of the radius)')
        if dt > limit:
            msg = (f'unstable contact {where}: at that overlap the contact needs dt <= '
                   f'{limit:.3e} s, the run uses dt = {dt:.3e} s; set sim.time_step_s to '
                   f'{0.5 * limit:.2e} s or less (or lower sim.rayleigh_safety; Rayleigh-based '
                   f'stable dt <= {stable_time_step(state, params):.3e} s)')
            raise SimulationError(msg)
        if row[0] > params.max_overlap_fraction:
            msg = (f'overlap {where} exceeds SimParams.max_overlap_fraction = '
                   f'{params.max_overlap_fraction} (sim.max_overlap_fraction): the contact is '
                   f'stable (its stable dt <= {limit:.3e} s, the run uses {dt:.3e} s), so raise '
                   f'the guard (default {DEFAULT_MAX_OVERLAP_FRACTION}) if such overlaps are '
                   f'expected, or make the contacts stiffer')
            raise SimulationError(msg)


def unstable_overlap(state: SimState, walls: Sequence[Plane], tool_material: int,
                     params: SimParams, dt: float) -> float:
    """Overlap / radius below which no contact of ``state`` can be unstable at ``dt`` [1].

    A lower bound over every pair kind (particle-particle, -wall, -tool) for the smallest
    particle of each material, where contacts are stiffest for their mass; `check_contacts`
    evaluates the deepest contacts exactly only above it.
    """
    if state.n == 0:
        return math.inf
    mats = {int(m) for m in np.unique(state.material)}
    others = mats | {p.material for p in walls} | {tool_material}
    best = math.inf
    for a in mats:
        r = float(state.radii[state.material == a].min())
        m = float(state.masses[state.material == a].min())
        for b in others:
            if not params.has_interaction(a, b):
                continue
            pair = b in mats
            r_eff, m_eff = (r / 2, m / 2) if pair else (r, m)
            # omega^2 grows as sqrt(delta): solve contact_stable_step(delta) = dt for delta.
            step = contact_stable_step(params, a, b, r_eff, m_eff, r)  # at a full radius
            if math.isinf(step):
                continue
            best = min(best, (step / dt) ** 4)  # dt_c ~ delta^(-1/4): ratio where dt_c = dt
    return best


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
    msg = (f'energy blow-up at t = {state.time:.6f} s: a particle moves {courant:.2f} radii per '
           f'step (non-finite: {n_nonfinite}); {_lower_dt(state, params, dt)}, or check the '
           f'tool speed and the initial velocities of the particles')
    return SimulationError(msg)


def _lower_dt(state: SimState, params: SimParams, dt: float) -> str:
    """The time step in use, the stable one and the settings that lower it (message tail)."""
    return (f'dt = {dt:.3e} s, stable dt <= {stable_time_step(state, params):.3e} s: lower '
            f'sim.time_step_s or sim.rayleigh_safety')


def lost_error(state: SimState, lost: int, n_start: int, params: SimParams,
               dt: float) -> SimulationError:
    """The error for too many particles leaving the domain box.

    Args:
        state: The state at the time of the last loss.
        lost: Particles removed so far.
        n_start: Particles the run started with.
        params: The parameters (domain, time-step settings).
        dt: The time step in use [s].
    """
    msg = (f'{lost} particles ({100 * lost / max(n_start, 1):.1f}% of {n_start}) have left '
           f'the domain box {params.domain_min} - {params.domain_max} m by t = '
           f'{state.time:.6f} s: the bed is blowing up or escaping the bin; '
           f'{_lower_dt(state, params, dt)}, or make the bin taller (bin.height_y_m)')
    return SimulationError(msg)


def inside_domain(state: SimState, params: SimParams, removed: int, n_start: int,
                  dt: float, lost_min: int, lost_fraction: float) -> NDArray[np.bool_]:
    """(n,) whether each particle is inside the domain box; the ones outside are logged.

    Args:
        removed: Particles removed earlier in the run.
        n_start: Particles the run started with.
        lost_min, lost_fraction: A run stops when more than both this many and this fraction
            of n_start particles left the box (single grains thrown out are only counted).

    Raises:
        SimulationError: Too many particles left the box (see `lost_error`).
    """
    keep: NDArray[np.bool_] = np.all((state.positions >= np.asarray(params.domain_min))
                                     & (state.positions <= np.asarray(params.domain_max)),
                                     axis=1)
    gone = state.ids[~keep]
    if removed + len(gone) > max(lost_min, lost_fraction * n_start):
        raise lost_error(state, removed + len(gone), n_start, params, dt)
    logger.warning('removed %d particle(s) that left the domain box at t = %.6f s (ids %s)',
                   len(gone), state.time, gone[:10].tolist())
    return keep
