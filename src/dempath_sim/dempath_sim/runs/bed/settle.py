"""Settling the poured bed, and compacting it to the scene's target bulk density.

A settle steps the bed in runs of ``SETTLE_CHECK_S`` until the fastest particle is slower than
``fill.settle_speed_m_s`` (never before ``MIN_SETTLE_S``). A bed looser than the target is
compacted by settling it again with friction and rolling resistance scaled down (a bisection
on the scale, each trial from the last bed that was still too loose) until its bulk density is
within ``fill.tolerance``; a target out of reach stops with one SceneError.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

import numpy as np

from dempath_sim.effects import PhysicsModel
from dempath_sim.engine import Engine
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.errors import SceneError
from dempath_sim.runs.bed.measure import measure
from dempath_sim.runs.bed.pour import target_solid_fraction
from dempath_sim.runs.bed.standing_tool import FillTool, fill_engine
from dempath_sim.runs.physics import scaled_friction
from dempath_sim.scene.spec import SceneSpec

logger = logging.getLogger(__name__)

COMPACTION_TRIALS = 7  # friction-scale bisection steps before a target counts as unreachable
COMPACTION_SETTLE_S = 0.4  # longest settle of one compaction trial [s]
SETTLE_CHECK_S = 0.02  # sim time between settling checks [s]
MIN_SETTLE_S = 0.1  # never stop before this much sim time [s]


Progress = Callable[[float, float], None]  # (sim time [s], max settle time [s])


def settle(engine: Engine, state: SimState, scene: SceneSpec, until_s: float,
           progress: Progress | None = None) -> tuple[SimState, bool]:
    """Step until the fastest particle is slower than the settling speed (or ``until_s``)."""
    engine.bind(state)
    dt = float(engine.dt or 0.0)
    chunk = max(1, round(SETTLE_CHECK_S / dt))
    start, vmax = state.time, math.inf
    while state.time < until_s:
        state = engine.run(state, chunk)
        if progress is not None:
            progress(state.time, scene.fill.max_settle_time_s)
        vmax = float(np.sqrt((state.velocities**2).sum(axis=1)).max(initial=0.0))
        if state.time - start >= MIN_SETTLE_S and vmax < scene.fill.settle_speed_m_s:
            return state, True
    logger.warning('fill: bed still moving (%.3g m/s) after %.2f s; using it anyway', vmax,
                   state.time)
    return state, False


def pour_and_settle(scene: SceneSpec, state: SimState, params: SimParams,
                    progress: Progress | None = None,
                    tool: FillTool | None = None) -> tuple[SimState, bool]:
    """Settle the poured state, first with scaled friction when ``fill.friction_scale`` < 1
    (around ``tool`` standing at its start, when given)."""
    limit = scene.fill.max_settle_time_s
    factor = scene.fill.friction_scale
    if factor < 1.0:
        state, _ = settle(fill_engine(scene, scaled_friction(params, factor), tool), state,
                          scene, limit / 2, progress)
    return settle(fill_engine(scene, params, tool), state, scene, limit, progress)


def _copy(state: SimState) -> SimState:
    return state.subset(np.ones(state.n, bool))


def unreachable(scene: SceneSpec, found: dict[str, float], what: str) -> SceneError:
    """The one error of a bulk density target ``what`` (a pour, a compaction) cannot reach."""
    target = scene.fill.bulk_density_target_kg_m3
    return SceneError(
        f'{scene.source}: fill.bulk_density_target_kg_m3: {target:g} kg/m^3 cannot be reached '
        f'within {100 * scene.fill.tolerance:g} %: {what} gives '
        f"{found['bulk_density_kg_m3']:.0f} kg/m^3 (solid fraction "
        f"{found['solid_fraction']:.3f})")


def compact(scene: SceneSpec, model: PhysicsModel, params: SimParams, state: SimState,
            progress: Progress | None = None,
            tool: FillTool | None = None) -> tuple[SimState, float]:
    """Settle the bed with friction scaled down until its bulk density reaches the target.

    Bisection on the friction scale in (0, 1): a trial settles the last bed that was still
    too loose with that scale; too loose, it becomes the new start and the scale goes down;
    too dense, the scale goes up. Returns the bed within the tolerance and the scale used.

    Raises:
        SceneError: The target is denser than the bed reaches with friction scaled to ~0.
    """
    phi_t = target_solid_fraction(scene, model)
    tol = scene.fill.tolerance * phi_t
    hi, lo, found = 1.0, 0.0, measure(scene, model, state)
    for _ in range(COMPACTION_TRIALS):
        scale = 0.5 * (hi + lo)
        trial, _ = settle(fill_engine(scene, scaled_friction(params, scale), tool),
                          _copy(state), scene, state.time + COMPACTION_SETTLE_S, progress)
        found = measure(scene, model, trial)
        logger.info('fill: compaction with friction x %.3g: solid fraction %.4f (target %.4f)',
                    scale, found['solid_fraction'], phi_t)
        if abs(found['solid_fraction'] - phi_t) <= tol:
            return trial, scale
        if found['solid_fraction'] < phi_t:
            hi, state = scale, trial
        else:
            lo = scale
    raise unreachable(scene, found, f'compaction down to friction x {0.5 * (hi + lo):.3g}')
