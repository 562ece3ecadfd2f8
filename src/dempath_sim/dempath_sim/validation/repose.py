"""Angle of repose of a lifted-cylinder discharge with the paper's Table 6 parameters.

The paper calibrated its sand on a laboratory angle-of-repose device (Kuře & Kuřetová,
Technologies 2025, 13, 570, Sec. 2.6.2 and 3.4; device of Černilová et al. 2022: sand in a
transparent cylinder discharged onto a base, the pile photographed) and reports 30.82 deg
measured from the base of the pile and 26.42 deg from the top in the experiment, and 30 deg /
26.6 deg for the selected Rocky model (Table 6: E 1.70 MPa, rolling resistance 0.26, dynamic
friction 0.59, static friction 0.71; Table 2: Poisson 0.25, restitution 0.30, particle-boundary
friction 0.40 / 0.30). The paper does not give the device's dimensions; here a steel cylinder
of inner diameter ``diameter`` is filled with 4 mm spheres (the paper's top-layer size, +-10 %),
settled, lifted at ``lift_speed`` and the pile left to rest on a steel base. The lift speed
is the set-up choice that moves the angle most (0.2 m/s: 13 deg, 0.05 m/s: 26 deg, 0.02 m/s:
31 deg from the base on the 50 mm tube); the default 0.02 m/s is a slow, near quasi-static lift.
The pile's angles are read in :mod:`dempath_sim.validation.pile`.

Set-ups (``PRESETS``, all lifted at 0.02 m/s): ``quick`` (36 mm tube, 561 spheres),
``standard`` (50 mm, 1,846 spheres, the ``dempath validate`` default) and ``large`` (100 mm,
10,400 spheres, ``dempath validate --repose large``); docs/validation_repose.md gives their
angles per seed and what moves them.
"""

from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath.dumpio import read_dump
from dempath_sim.engine import Interaction, SimParams, ToolPose, TriangleMesh
from dempath_sim.liggghts import commands as cmd
from dempath_sim.validation import cases
from dempath_sim.validation.pile import ReposeResult, repose_angles

F64 = NDArray[np.float64]
logger = logging.getLogger(__name__)
PAPER_EXPERIMENT_DEG = (30.82, 26.42)  # (from the base, from the top), Sec. 3.4
PAPER_ROCKY_DEG = (30.0, 26.6)


@dataclass(frozen=True)
class ReposeCase:
    """Set-up of the discharge.

    Attributes:
        diameter: Inner diameter of the cylinder [m].
        fill_height: Height of the loose lattice the particles start in [m].
        particle_diameter: Mean particle diameter [m] (+-spread uniform).
        spread: Relative half-width of the uniform size distribution [-].
        lift_speed: Cylinder lift speed [m/s].
        settle_s: Settling time before the lift [s].
        rest_s: Time after the lift for the pile to come to rest [s].
        seed: Seed of the initial lattice jitter and sizes.
        density: Particle density [kg/m^3] (the scenes' 1734).
        rest_speed: dempath stops the rest phase early once no sphere moves faster [m/s].
    """

    diameter: float = 0.05
    fill_height: float = 0.12
    particle_diameter: float = 0.004
    spread: float = 0.1
    lift_speed: float = 0.02
    settle_s: float = 0.5
    rest_s: float = 0.6
    seed: int = 0
    density: float = 1734.0
    rest_speed: float = 0.005

    @property
    def cylinder_height(self) -> float:
        """Height of the tube [m]."""
        return self.fill_height + 0.02

    LOOSEST_PACKING = 0.45  # solid fraction below any settled column here (measured ~0.5) [-]

    @property
    def lift_height(self) -> float:
        """How far the tube is lifted [m]: two grains above the top the settled column would
        have at a solid fraction of 0.45 (looser than the ~0.5 measured, so the rim clears
        the material; a higher lift only moves the empty tube longer)."""
        _, radii = self.particles()
        volume = float(np.sum(4 / 3 * math.pi * radii ** 3))
        top = volume / (self.LOOSEST_PACKING * math.pi * (self.diameter / 2) ** 2)
        return min(top, self.fill_height) + 2 * self.particle_diameter

    @property
    def lift_s(self) -> float:
        """Duration of the lift [s]."""
        return self.lift_height / self.lift_speed

    def params(self) -> SimParams:
        """Sand (0), steel base (1), steel cylinder (2): Tables 2 and 6 of the paper."""
        pp = Interaction(0.3, 0.71, 0.59, 0.26)
        pb = Interaction(0.3, 0.40, 0.30, 0.26)
        return cases.case_params(cases.sand(self.density), pp, pb, walls=2,
                                 domain_min=(-0.5, -0.05, -0.5), domain_max=(0.5, 0.5, 0.5),
                                 max_overlap_fraction=0.3)

    def particles(self) -> tuple[F64, F64]:
        """Jittered lattice centres (n, 3) [m] inside the tube and radii (n,) [m]."""
        rng = np.random.default_rng(self.seed)
        d_max = self.particle_diameter * (1 + self.spread)
        a = 1.05 * d_max
        # Keep centre + jitter + radius inside the tube: jitter <= 0.9 (a - d_min) / 2 per axis.
        jitter = 0.9 * (a - self.particle_diameter * (1 - self.spread)) / 2
        reach = self.diameter / 2 - d_max / 2 - math.sqrt(2) * jitter
        g = np.arange(-reach, reach + 1e-12, a)
        xs, ys, zs = np.meshgrid(g, np.arange(d_max / 2, self.fill_height, a), g,
                                 indexing='ij')
        pos = np.column_stack([xs.ravel(), ys.ravel(), zs.ravel()])
        pos = pos[np.hypot(pos[:, 0], pos[:, 2]) <= reach]
        radii = self.particle_diameter / 2 * (1 + self.spread * rng.uniform(-1, 1, len(pos)))
        pos += rng.uniform(-1, 1, pos.shape) * (a - 2 * radii[:, None]) / 2 * 0.9
        return pos, radii

    def tube(self, segments: int = 48) -> F64:
        """Triangles (2 segments, 3, 3) [m] of the open tube standing on y = 0.2 mm."""
        ang = np.linspace(0, 2 * math.pi, segments + 1)
        r, y0, y1 = self.diameter / 2, 2e-4, self.cylinder_height
        tris = []
        for a0, a1 in itertools.pairwise(ang):
            p0 = (r * math.cos(a0), y0, r * math.sin(a0))
            p1 = (r * math.cos(a1), y0, r * math.sin(a1))
            q0 = (r * math.cos(a0), y1, r * math.sin(a0))
            q1 = (r * math.cos(a1), y1, r * math.sin(a1))
            tris += [(p0, p1, q1), (p0, q1, q0)]
        return np.array(tris)


PRESETS: dict[str, dict[str, float]] = {
    'quick': {'diameter': 0.036, 'fill_height': 0.08},
    'standard': {},
    'large': {'diameter': 0.1, 'fill_height': 0.15},
}


def preset_case(name: str, seed: int = 0,
                overrides: dict[str, float] | None = None) -> ReposeCase:
    """The ``PRESETS[name]`` set-up with packing seed ``seed`` and ``overrides`` applied.

    Raises:
        ValueError: ``name`` is not a preset, or an override is not a float field of
            ReposeCase or is not positive.
    """
    if name not in PRESETS:
        msg = f'repose preset {name!r}: expected one of {sorted(PRESETS)}'
        raise ValueError(msg)
    free = [f.name for f in fields(ReposeCase) if f.type in ('float', float)]
    for key, value in (overrides or {}).items():
        if key not in free or not (value >= 0 if key == 'spread' else value > 0):
            msg = (f'repose override {key}={value!r}: expected one of {free}, positive '
                   '(spread may be 0)')
            raise ValueError(msg)
    kw = {**PRESETS[name], **(overrides or {})}
    return ReposeCase(seed=seed, **kw)  # type: ignore[arg-type]


def repose_dempath(case: ReposeCase) -> ReposeResult:
    """Fill, settle, lift and measure on the dempath engine.

    The rest phase runs in 0.05 s chunks and stops once no sphere moves faster than
    ``case.rest_speed`` (or after ``case.rest_s``).
    """
    pos, radii = case.particles()
    engine, state = cases.dempath_run(case.params(), pos, radii, [cases.FLOOR],
                                      TriangleMesh(case.tube(), material=2, name='tube'))
    engine.bind(state)
    dt = float(engine.dt or 0.0)
    state = engine.run(state, int(case.settle_s / dt))
    top = float(np.max(state.positions[:, 1] + state.radii))
    logger.info('repose: settled column top %.4f m, rim lifted to %.4f m', top, case.lift_height)
    if top > case.lift_height:
        logger.warning('repose: settled column top %.4f m above the lifted rim %.4f m', top,
                       case.lift_height)
    t0, v = state.time, case.lift_speed

    def lift(t: float) -> ToolPose:
        up = min(max(t - t0, 0.0), case.lift_s)
        moving = v if t - t0 < case.lift_s else 0.0
        return ToolPose(np.array([0.0, v * up, 0.0]), np.array([0.0, moving, 0.0]))

    state = engine.run(state, int(case.lift_s / dt), tool_motion=lift)
    chunk = max(1, int(0.05 / dt))
    for _ in range(max(1, int(case.rest_s / (chunk * dt)))):
        state = engine.run(state, chunk, tool_motion=lift)
        if float(np.abs(state.velocities).max(initial=0.0)) < case.rest_speed:
            break
    logger.info('repose dempath: %d spheres, %.2f s simulated', state.n, state.time)
    return repose_angles('dempath', state.positions, state.radii, state.time)


def repose_liggghts(case: ReposeCase, workdir: Path, dt: float, nprocs: int = 1,
                    friction: str = 'static') -> ReposeResult:
    """The same discharge on LIGGGHTS with time step ``dt`` [s]."""
    params = case.params()
    pos, radii = case.particles()
    workdir.mkdir(parents=True, exist_ok=True)
    cmd.write_ascii_stl(str(workdir / 'tube.stl'), case.tube().tolist(), 'tube')
    big = 0.3
    lines = cases.liggghts_preamble(params, (-big, -0.01, -big),
                                    (big, 2 * case.cylinder_height + 0.05, big),
                                    0.5 * case.particle_diameter, dt, friction)
    lines += [cmd.plane_wall('base', params, 'y', 0.0, 1),
              'fix tube all mesh/surface file tube.stl type 3',
              cmd.mesh_wall('tubewall', params, ['tube'])]
    for k, (p, r) in enumerate(zip(pos, radii, strict=True)):
        lines += [f'create_atoms 1 single {cmd.fmt(p[0])} {cmd.fmt(p[1])} {cmd.fmt(p[2])} '
                  'units box', f'set atom {k + 1} diameter {cmd.fmt(2 * r)} density '
                  f'{cmd.fmt(case.density)}']
    lines += ['fix integr all nve/sphere', 'thermo_modify lost ignore norm no',
              'thermo 5000', f'run {int(case.settle_s / dt)}',
              f'fix lift all move/mesh mesh tube linear 0 {cmd.fmt(case.lift_speed)} 0',
              f'run {int(case.lift_s / dt)}', 'unfix lift',
              f'run {int(case.rest_s / dt)}',
              'write_dump all custom pile.dump id x y z radius']
    cases.run_liggghts(workdir, 'repose', lines, nprocs)
    frame = read_dump(workdir / 'pile.dump')[-1]
    xyz = frame.data[:, 1:4]
    sim_time = case.settle_s + case.lift_s + case.rest_s
    return repose_angles('liggghts', xyz, frame.column('radius'), sim_time)
