"""Scene -> the LIGGGHTS 3.8 tool deck (``in.tool``): the pass on the settled bed.

``read_data`` of the settled bed (positions, velocities, spins and sizes from the fill's dump
(:mod:`dempath_sim.liggghts.fill_deck`), written by Python: contact histories start at zero, as
in dempath's pass, where a new engine starts from the settled or cached packing), the same
physics, the tool STL (ASCII, placed in world coordinates) as ``fix mesh/surface/stress`` with its
reference point at the tip, moved by ``fix move/mesh linear/variable`` with the piecewise speed
profile, a dump of the tracked ids and a force/torque print every output interval, full-bed
snapshots.

Material types: 1 particles, 2 walls, 3 tool (dempath indices + 1).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine.params import SimParams
from dempath_sim.liggghts import commands as cmd
from dempath_sim.liggghts.fill_deck import BED_DATA
from dempath_sim.scene.profiles import ToolPath
from dempath_sim.scene.spec import SceneSpec

TRACKED_DUMP = 'tracked.dump'
SNAPSHOT_DUMP = 'snapshots.dump'
TOOL_FILE = 'tool.txt'
TOOL_STL = 'tool.stl'


def velocity_expression(path: ToolPath) -> str:
    """LIGGGHTS equal-style expression of the tool speed [m/s] at ``v_t`` (sim time)."""
    p = path.profile
    t0 = path.start_time_s
    t1 = p.acceleration_time_s
    t2 = t1 + p.steady_time_s
    t3 = t2 + p.deceleration_time_s
    tp = f'(v_t+{cmd.fmt(t0)})'
    acc = f'({tp}<{cmd.fmt(t1)})*{cmd.fmt(p.acceleration_m_s2)}*{tp}'
    steady = f'({tp}>={cmd.fmt(t1)})*({tp}<{cmd.fmt(t2)})*{cmd.fmt(p.speed_m_s)}'
    dec = (f'({tp}>={cmd.fmt(t2)})*({tp}<{cmd.fmt(t3)})*({cmd.fmt(p.speed_m_s)}-'
           f'{cmd.fmt(p.deceleration_m_s2)}*({tp}-{cmd.fmt(t2)}))')
    return f'{acc}+{steady}+{dec}'


def _stopped(expression: str, stop_s: float) -> str:
    """``expression`` (of ``v_t``) set to 0 from ``stop_s`` on (infinite: unchanged)."""
    return expression if math.isinf(stop_s) else f'({expression})*(v_t<{cmd.fmt(stop_s)})'


def group_lines(name: str, ids: Sequence[int] | NDArray[np.int64],
                per_line: int = 200) -> list[str]:
    """``group NAME id ...`` split over several lines (a group adds up)."""
    ints = [int(i) for i in ids]
    return [f'group {name} id ' + ' '.join(str(i) for i in ints[k:k + per_line])
            for k in range(0, len(ints), per_line)]


def _slot_lines(ids: NDArray[np.int64]) -> list[str]:
    if not len(ids):
        return []
    # After a read_restart, LIGGGHTS deletes atoms only after a first run (run 0 here).
    return [*group_lines('slot', ids), 'run 0', 'delete_atoms group slot compress no']


@dataclass(frozen=True)
class ToolStage:
    """What the tool deck needs beyond the scene.

    Attributes:
        path: Tool reference point (tip) path in world coordinates.
        tracked_ids: LIGGGHTS ids of the markers and candidates.
        start_step: Step number at time 0 of the pass (0: the deck resets the step count).
        slot_ids: Ids removed before the pass (the tool's slot, as dempath's run does).
        duration_s: Simulated time of the pass [s].
        dt: Time step [s] (divides the output interval).
        output_every: Steps between outputs.
        snapshot_every: Steps between full-bed snapshots (0 = none).
        read: The command that loads the bed (the fill's restart, or a data file).
        settle_steps: Steps of re-settle with the tool standing at its start before the pass
            (``tool.settle_s``; builds the contact history, as dempath's run does).
        stop_s: Pass time [s] from which the tool stands still (the bed is followed after the
            travel, ``RunOptions.follow_s``); infinite: the profile's own end.
    """

    path: ToolPath
    tracked_ids: NDArray[np.int64]
    start_step: int
    slot_ids: NDArray[np.int64]
    duration_s: float
    dt: float
    output_every: int
    snapshot_every: int
    read: str = f'read_data {BED_DATA}'
    settle_steps: int = 0
    stop_s: float = math.inf


def tool_deck(scene: SceneSpec, params: SimParams, stage: ToolStage,
              friction: str = 'static') -> str:
    """The ``in.tool`` deck text (see the module docstring)."""
    tip = [cmd.fmt(v) for v in stage.path.start_position_m]
    steps = math.ceil(stage.duration_s / stage.dt / stage.output_every) * stage.output_every
    lines = ['atom_style granular', 'atom_modify map array', 'boundary f f f', 'newton off',
             'communicate single vel yes', 'units si']
    lines += ['soft_particles yes'] if cmd.needs_soft(params) else []
    lines += [f'processors {cmd.SPLIT}']
    big = 2 * max(max(layer.diameter_m for layer in scene.layers), 1e-3)
    lines += ['hard_particles yes', stage.read,
              f'neighbor {cmd.fmt(0.3 * big)} bin', 'neigh_modify delay 0',
              *cmd.physics(params, stage.dt, friction), *cmd.bin_walls(scene, params, 1),
              *_slot_lines(stage.slot_ids),
              f'fix tool all mesh/surface/stress file {TOOL_STL} type 3 reference_point '
              f'{" ".join(tip)}', cmd.mesh_wall('toolwall', params, ['tool']),
              *([f'run {stage.settle_steps}'] if stage.settle_steps else []),
              f'variable t equal (step-{stage.start_step})*dt',
              f'variable vz equal {_stopped(velocity_expression(stage.path), stage.stop_s)}',
              'variable zero equal 0',
              'fix mv all move/mesh mesh tool linear/variable v_zero v_zero v_vz',
              *group_lines('tracked', stage.tracked_ids),
              f'dump dtr tracked custom {stage.output_every} {TRACKED_DUMP} id x y z vx vy vz',
              'dump_modify dtr sort id']
    if stage.snapshot_every:
        lines += [f'dump dsn all custom {stage.snapshot_every} {SNAPSHOT_DUMP} id x y z',
                  'dump_modify dsn sort id']
    lines += [f'variable f{k} equal f_tool[{k}]' for k in range(1, 10)]
    vals = ' '.join(f'${{f{k}}}' for k in range(1, 10))
    lines += [f'fix ftool all print {stage.output_every} "${{t}} {vals}" file {TOOL_FILE} '
              'screen no', 'thermo_style custom step atoms ke',
              'thermo_modify lost ignore norm no', f'thermo {stage.output_every * 10}',
              # Time 0 of the pass is step 0, so output steps (multiples of output_every)
              # fall on the output times whatever step the fill ended on; after a restart,
              # LIGGGHTS wants reset_timestep right before run.
              'reset_timestep 0', f'run {steps}']
    return '\n'.join(lines) + '\n'
