"""Scene -> the LIGGGHTS 3.8 fill deck (``in.fill``): the bin, the loose bed and its settle.

The run has two stages, as the dempath engine has (fill, then the tool pass on the settled bed;
the pass is :mod:`dempath_sim.liggghts.tool_deck`). The fill:

``in.fill``: the bin as primitive ``wall/gran`` planes (floor, four sides, open top) and
the loose initial bed, then the settle with dempath's criterion (the fastest particle slower
than ``fill.settle_speed_m_s``, checked every ``SETTLE_CHECK_S``, at least ``MIN_SETTLE_S``,
at most ``fill.max_settle_time_s``; a first stage with friction and rolling resistance times
``fill.friction_scale`` up to half that time when the scale is < 1, as ``fill.pour_and_settle``
does); ``write_restart`` and a dump of every particle. The loose bed is either dempath's own
pour of the same seed (``fill.pour``: the jittered lattice and its small random velocities,
read with ``read_data``; the default, see ``pour_fill_deck``) or, with ``insert_fill_deck``,
each layer inserted by ``fix insert/pack`` into its own slab at ``INSERT_SOLID_FRACTION``
with dempath's particle count (target solid fraction x layer volume).

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
from dempath_sim.scene.spec import LayerSpec, SceneSpec

FILL_DUMP = 'fill.dump'
FILL_RESTART = 'fill.restart'
BED_DATA = 'bed.data'  # the settled bed the pass starts from
POUR_DATA = 'pour.data'
POUR_DUMP = 'pour.dump'  # the loose bed as LIGGGHTS read it
INSERT_SOLID_FRACTION = 0.2  # loose random packing insert/pack reaches in one go
DISCRETE_BINS = 5  # templates approximating a uniform size distribution
SETTLE_CHECK_S = 0.02  # as dempath_sim.runs.bed.settle
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
                       processors=cmd.SPLIT)
    lines += ['hard_particles yes', *cmd.physics(params, dt, friction),
              *cmd.bin_walls(scene, params, 1)]
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
    lines += [f'processors {cmd.SPLIT}', 'hard_particles yes', f'read_data {data_file}',
              f'neighbor {cmd.fmt(skin_m)} bin', 'neigh_modify delay 0',
              f'write_dump all custom {POUR_DUMP} id x y z vx vy vz radius',
              *cmd.physics(params, dt, friction), *cmd.bin_walls(scene, params, 1),
              *_fill_tail(scene, params, dt, friction)]
    return '\n'.join(lines) + '\n'


