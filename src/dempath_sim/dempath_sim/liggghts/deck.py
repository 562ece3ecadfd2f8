"""Scene -> LIGGGHTS 3.8 input decks: a fill deck (pour and settle) and a tool deck (the pass).

The run has two stages, as the dempath engine has (fill, then the tool pass on the settled bed):

1. ``in.fill``: the bin as primitive ``wall/gran`` planes (floor, four sides, open top) and
   the loose initial bed, then the settle with dempath's criterion (the fastest particle slower
   than ``fill.settle_speed_m_s``, checked every ``SETTLE_CHECK_S``, at least ``MIN_SETTLE_S``,
   at most ``fill.max_settle_time_s``; a first stage with friction and rolling resistance times
   ``fill.friction_scale`` up to half that time when the scale is < 1, as ``fill.pour_and_settle``
   does); ``write_restart`` and a dump of every particle. The loose bed is either dempath's own
   pour of the same seed (``fill.pour``: the jittered lattice and its small random velocities,
   read with ``read_data``; the default, see ``pour_fill_deck``) or, with ``insert_fill_deck``,
   each layer inserted by ``fix insert/pack`` into its own slab at ``INSERT_SOLID_FRACTION``
   with dempath's particle count (target solid fraction x layer volume).
2. ``in.tool``: ``read_data`` of the settled bed (positions, velocities, spins and sizes from
   the fill's dump, written by Python: contact histories start at zero, as in dempath's pass,
   where a new engine starts from the settled or cached packing), the same physics, the tool
   STL (ASCII, placed in world coordinates) as ``fix mesh/surface/stress`` with its reference
   point at the tip, moved by ``fix move/mesh linear/variable`` with the piecewise speed
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
from dempath_sim.runs.physics import scaled_friction
from dempath_sim.scene.profiles import ToolPath
from dempath_sim.scene.spec import LayerSpec, SceneSpec

FILL_DUMP = 'fill.dump'
FILL_RESTART = 'fill.restart'
BED_DATA = 'bed.data'  # the settled bed the pass starts from
TRACKED_DUMP = 'tracked.dump'
SNAPSHOT_DUMP = 'snapshots.dump'
TOOL_FILE = 'tool.txt'
TOOL_STL = 'tool.stl'
POUR_DATA = 'pour.data'
POUR_DUMP = 'pour.dump'  # the loose bed as LIGGGHTS read it
INSERT_SOLID_FRACTION = 0.2  # loose random packing insert/pack reaches in one go
DISCRETE_BINS = 5  # templates approximating a uniform size distribution
SETTLE_CHECK_S = 0.02  # as dempath_sim.runs.bed.settle
SPLIT = '* 1 *'  # MPI grid: split X and Z only (bed below, empty tool space above)
MIN_SETTLE_S = 0.1


@dataclass(frozen=True)
class FillPlan:
    """Particle templates and counts per layer, and the slabs they are inserted into.

    Attributes:
        diameters: Per layer, the template diameters [m].
        fractions: Per layer, the mass fraction of each template [1].
        counts: Particles per layer.
        slabs: Per layer, (y_low, y_high) of the insertion slab [m].
    """

    diameters: tuple[tuple[float, ...], ...]
    fractions: tuple[tuple[float, ...], ...]
    counts: tuple[int, ...]
    slabs: tuple[tuple[float, float], ...]

    @property
    def top(self) -> float:
        """Top of the highest insertion slab [m]."""
        return self.slabs[-1][1]


def layer_templates(layer: LayerSpec, factor: float) -> tuple[tuple[float, ...],
                                                              tuple[float, ...]]:
    """Template diameters [m] and mass fractions of a layer (uniform -> DISCRETE_BINS bins)."""
    d0, dist = layer.diameter_m * factor, layer.distribution
    if dist.kind == 'discrete':
        w = np.asarray(dist.mass_fractions, dtype=float)
        return tuple(d * factor for d in dist.diameters_m), tuple(w / w.sum())
    if dist.kind == 'uniform' and dist.spread > 0:
        # Uniform in d: equal number per bin, mass fraction proportional to d^3.
        edges = np.linspace(1 - dist.spread, 1 + dist.spread, DISCRETE_BINS + 1)
        d = d0 * 0.5 * (edges[1:] + edges[:-1])
        return tuple(d), tuple(d ** 3 / np.sum(d ** 3))
    return (d0,), (1.0,)


def fill_plan(scene: SceneSpec, coarse_grain: float, solid_fraction: float) -> FillPlan:
    """Counts per layer as dempath's pour (solid fraction x layer volume) and stacked slabs."""
    area = scene.bin.width_x_m * scene.bin.length_z_m
    y = -scene.bed_thickness_m
    diam, frac, counts, slabs = [], [], [], []
    for layer in scene.layers:
        factor = coarse_grain if layer.coarse_grained else 1.0
        d, w = layer_templates(layer, factor)
        # Mean particle volume of the mass-weighted mix: sum(w) / sum(w / v).
        v = (math.pi / 6) * np.asarray(d) ** 3
        mean_v = 1.0 / float(np.sum(np.asarray(w) / v))
        solid = solid_fraction * area * layer.thickness_m
        counts.append(max(1, round(solid / mean_v)))
        height = solid / (INSERT_SOLID_FRACTION * area) + max(d)
        slabs.append((y, y + height))
        diam.append(d)
        frac.append(w)
        y += height
    return FillPlan(tuple(diam), tuple(frac), tuple(counts), tuple(slabs))


def write_data(path: str, ids: NDArray[np.int64], positions: NDArray[np.float64],
               velocities: NDArray[np.float64], omegas: NDArray[np.float64],
               radii: NDArray[np.float64], density: float, n_types: int,
               box: tuple[Sequence[float], Sequence[float]]) -> None:
    """A LIGGGHTS data file of a packing (atom_style granular: id type diameter density x y z;
    Velocities: id vx vy vz wx wy wz), type 1 for every sphere."""
    lo, hi = box
    head = [f'dempath packing of {len(ids)} spheres', '', f'{len(ids)} atoms',
            f'{n_types} atom types',
            *(f'{cmd.fmt(lo[k])} {cmd.fmt(hi[k])} {a}lo {a}hi' for k, a in enumerate('xyz')),
            '', 'Atoms', '']
    atoms = [f'{i} 1 {2 * r:.9g} {cmd.fmt(density)} {p[0]:.9g} {p[1]:.9g} {p[2]:.9g}'
             for i, p, r in zip(ids.tolist(), positions, radii, strict=True)]
    vels = [f'{i} {v[0]:.6g} {v[1]:.6g} {v[2]:.6g} {w[0]:.6g} {w[1]:.6g} {w[2]:.6g}'
            for i, v, w in zip(ids.tolist(), velocities, omegas, strict=True)]
    with open(path, 'w') as fh:
        fh.write('\n'.join([*head, *atoms, '', 'Velocities', '', *vels]) + '\n')


def primes_from(seed: int, count: int) -> list[int]:
    """``count`` distinct primes > 10000 derived from ``seed`` (LIGGGHTS wants prime seeds)."""
    out: list[int] = []
    n = 10007 + 7919 * (seed % 100000)
    while len(out) < count:
        if n > 1 and all(n % k for k in range(2, math.isqrt(n) + 1)):
            out.append(n)
        n += 2 if n % 2 else 1
    return out


def box_bounds(scene: SceneSpec, top: float, margin: float,
               extent: tuple[Sequence[float], Sequence[float]] | None = None,
               ) -> tuple[list[float], list[float]]:
    """Simulation box: the bin plus ``margin`` up to ``top`` [m], grown to hold ``extent``.

    LIGGGHTS deletes mesh elements outside the box, so ``extent`` is the (lo, hi) bounding box
    the tool sweeps during the pass; the box is fixed in the restart file of the fill.
    """
    w, floor = scene.bin.width_x_m / 2, -scene.bed_thickness_m
    lo = [-w - margin, floor - margin, -margin]
    hi = [w + margin, max(top, floor + scene.bin.height_y_m) + margin,
          scene.bin.length_z_m + margin]
    if extent is not None:
        lo = [min(a, b - margin) for a, b in zip(lo, extent[0], strict=True)]
        hi = [max(a, b + margin) for a, b in zip(hi, extent[1], strict=True)]
    return lo, hi


def physics(params: SimParams, dt: float, friction: str) -> list[str]:
    """Materials, contact law, gravity, time step and the integrator."""
    return [*cmd.materials(params, friction), *cmd.pair_style(params), *cmd.gravity(params),
            f'timestep {cmd.fmt(dt)}', 'fix integr all nve/sphere']


def bin_walls(scene: SceneSpec, params: SimParams, wall_type: int) -> list[str]:
    """Floor and four side walls of the bin as primitive planes (open top)."""
    w, floor = scene.bin.width_x_m / 2, -scene.bed_thickness_m
    planes = (('y', floor), ('x', -w), ('x', w), ('z', 0.0), ('z', scene.bin.length_z_m))
    return [cmd.plane_wall(f'wall{k}', params, axis, off, wall_type)
            for k, (axis, off) in enumerate(planes)]


def _insert_lines(scene: SceneSpec, plan: FillPlan) -> list[str]:
    w, length = scene.bin.width_x_m / 2, scene.bin.length_z_m
    seeds = iter(primes_from(scene.seed, 64))
    lines: list[str] = []
    for k, (ds, ws) in enumerate(zip(plan.diameters, plan.fractions, strict=True)):
        names = []
        for t, d in enumerate(ds):
            names.append(f'pts{k}_{t}')
            lines.append(f'fix {names[-1]} all particletemplate/sphere {next(seeds)} atom_type 1 '
                         f'density constant {{rho}} radius constant {cmd.fmt(d / 2)}')
        mix = ' '.join(f'{n} {cmd.fmt(x)}' for n, x in zip(names, ws, strict=True))
        lines.append(f'fix pdd{k} all particledistribution/discrete {next(seeds)} '
                     f'{len(names)} {mix}')
        gap = max(ds) / 2 * 1.01
        y0, y1 = plan.slabs[k]
        lines += [f'region slab{k} block {cmd.fmt(-w + gap)} {cmd.fmt(w - gap)} '
                  f'{cmd.fmt(y0 + gap)} {cmd.fmt(y1 - gap)} {cmd.fmt(gap)} '
                  f'{cmd.fmt(length - gap)} units box',
                  f'fix ins{k} all insert/pack seed {next(seeds)} distributiontemplate pdd{k} '
                  f'maxattempt 200 insert_every once overlapcheck yes all_in yes '
                  f'vel constant 0 0 0 region slab{k} particles_in_region {plan.counts[k]} '
                  f'ntry_mc 10000']
    return lines


def settle_lines(scene: SceneSpec, dt: float, stage: int, until_s: float,
                 start_s: float = 0.0, offset: int = 0) -> list[str]:
    """One settle stage, as ``dempath_sim.runs.bed.settle.settle``: runs of ``SETTLE_CHECK_S``
    until the fastest particle is slower than ``fill.settle_speed_m_s`` after at least
    ``MIN_SETTLE_S``, or until the step of ``until_s`` [s]; ``start_s`` [s] is the nominal start of
    the stage (the step count of each run is fixed, the stage's start step is read in the deck);
    ``offset`` is the step at which the pour starts (time 0 of the settle)."""
    chunk = max(1, round(SETTLE_CHECK_S / dt))
    min_chunks = math.ceil(MIN_SETTLE_S / (chunk * dt) - 1e-9)
    max_chunks = max(1, math.ceil((until_s - start_s) / (chunk * dt) - 1e-9))
    last = offset + math.ceil(until_s / (chunk * dt) - 1e-9) * chunk
    done = f'settled{stage}'
    return [f'variable k{stage} loop {max_chunks}', f'label settle{stage}', f'run {chunk}',
            'variable vm equal c_vmax', 'variable st equal step',
            f'if "${{k{stage}}} >= {min_chunks} && ${{vm}} < '
            f'{cmd.fmt(scene.fill.settle_speed_m_s)}" then "jump SELF {done}"',
            f'if "${{st}} >= {last}" then "jump SELF {done}"',
            f'next k{stage}', f'jump SELF settle{stage}', f'label {done}']


def _settle_stages(scene: SceneSpec, params: SimParams, dt: float, friction: str,
                   offset: int) -> list[str]:
    limit = scene.fill.max_settle_time_s
    factor = scene.fill.friction_scale
    monitor = ['variable sp atom sqrt(vx*vx+vy*vy+vz*vz)', 'compute vmax all reduce max v_sp',
               'thermo_style custom step atoms ke c_vmax', 'thermo_modify lost ignore norm no',
               f'thermo {max(1, round(SETTLE_CHECK_S / dt))}']
    if factor >= 1.0:
        return [*monitor, *settle_lines(scene, dt, 1, limit, 0.0, offset)]
    # Redefining a property/global fix (same id) replaces its values for the next run.
    return [*cmd.materials(scaled_friction(params, factor), friction), *monitor,
            *settle_lines(scene, dt, 1, limit / 2, 0.0, offset),
            *cmd.materials(params, friction),
            *settle_lines(scene, dt, 2, limit, limit / 2, offset)]


def _fill_tail(scene: SceneSpec, params: SimParams, dt: float, friction: str,
               offset: int = 0) -> list[str]:
    fmt = '%d %d' + ' %.12g' * 10
    return [*_settle_stages(scene, params, dt, friction, offset), f'write_restart {FILL_RESTART}',
            f'write_dump all custom {FILL_DUMP} id type x y z vx vy vz omegax omegay omegaz '
            f'radius modify format "{fmt}"']


def insert_fill_deck(scene: SceneSpec, params: SimParams, dt: float, plan: FillPlan,
                     friction: str = 'static',
                     extent: tuple[Sequence[float], Sequence[float]] | None = None) -> str:
    """The ``in.fill`` deck that inserts its own loose bed with ``fix insert/pack``.

    ``extent`` as in box_bounds; the insertion takes one check interval before the settle.
    """
    big = max(max(d) for d in plan.diameters)
    lo, hi = box_bounds(scene, plan.top, 2 * big, extent)
    rho = params.materials[0].density
    # Never split the domain along Y: the box is tall only to hold the tool, so a Y split would
    # leave one process without particles.
    lines = cmd.header(lo, hi, len(params.materials), 0.3 * big, cmd.needs_soft(params),
                       processors=SPLIT)
    lines += ['hard_particles yes', *physics(params, dt, friction),
              *bin_walls(scene, params, 1)]
    lines += [s.replace('{rho}', cmd.fmt(rho)) for s in _insert_lines(scene, plan)]
    check = max(1, round(SETTLE_CHECK_S / dt))
    lines += [f'run {check}', *[f'unfix ins{k}' for k in range(len(plan.counts))],
              *_fill_tail(scene, params, dt, friction, check)]
    return '\n'.join(lines) + '\n'


fill_deck = insert_fill_deck  # the name of earlier releases


def pour_fill_deck(scene: SceneSpec, params: SimParams, dt: float, skin_m: float,
                   data_file: str = POUR_DATA, friction: str = 'static') -> str:
    """The ``in.fill`` deck that settles dempath's loose pour, read from ``data_file``.

    The data file (``write_data``) holds the box, the spheres, their velocities and spins;
    ``skin_m`` is the neighbour skin [m].
    """
    lines = ['atom_style granular', 'atom_modify map array', 'boundary f f f', 'newton off',
             'communicate single vel yes', 'units si']
    lines += ['soft_particles yes'] if cmd.needs_soft(params) else []
    lines += [f'processors {SPLIT}', 'hard_particles yes', f'read_data {data_file}',
              f'neighbor {cmd.fmt(skin_m)} bin', 'neigh_modify delay 0',
              f'write_dump all custom {POUR_DUMP} id x y z vx vy vz radius',
              *physics(params, dt, friction), *bin_walls(scene, params, 1),
              *_fill_tail(scene, params, dt, friction)]
    return '\n'.join(lines) + '\n'


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
    lines += [f'processors {SPLIT}']
    big = 2 * max(max(layer.diameter_m for layer in scene.layers), 1e-3)
    lines += ['hard_particles yes', stage.read,
              f'neighbor {cmd.fmt(0.3 * big)} bin', 'neigh_modify delay 0',
              *physics(params, stage.dt, friction), *bin_walls(scene, params, 1),
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
