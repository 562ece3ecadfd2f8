"""Angle of repose of a lifted-cylinder discharge with the paper's Table 6 parameters.

The paper calibrated its sand on a laboratory angle-of-repose device (Kuře & Kuřetová,
Technologies 2025, 13, 570, Sec. 2.6.2 and 3.4; device of Černilová et al. 2022: sand in a
transparent cylinder discharged onto a base, the pile photographed) and reports 30.82 deg
measured from the base of the pile and 26.42 deg from the top in the experiment, and 30 deg /
26.6 deg for the selected Rocky model (Table 6: E 1.70 MPa, rolling resistance 0.26, dynamic
friction 0.59, static friction 0.71; Table 2: Poisson 0.25, restitution 0.30, particle-boundary
friction 0.40 / 0.30). The paper does not give the device's dimensions; here a steel cylinder
of inner diameter ``diameter`` is filled with 4 mm spheres (the paper's top-layer size, +-10 %),
settled, lifted at ``lift_speed`` and the pile left to rest on a steel base.

The angle is read from the pile's surface profile h(r) (highest particle top per radial ring,
averaged over angular sectors): the angle from the base is the slope of a line fitted where
h is 10-60 % of the peak, the angle from the top where h is 40-90 % (a stand-in for ESSS's
script, which the paper does not describe).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath_sim.liggghts import commands as cmd
from dempath_sim.liggghts.dumps import read_dump
from dempath_sim.liggghts.runner import run_deck
from dempath_sim.materials import Interaction, Material
from dempath_sim.params import SimParams

F64 = NDArray[np.float64]
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
    """

    diameter: float = 0.05
    fill_height: float = 0.12
    particle_diameter: float = 0.004
    spread: float = 0.1
    lift_speed: float = 0.05
    settle_s: float = 0.5
    rest_s: float = 0.6
    seed: int = 0
    density: float = 1734.0

    @property
    def cylinder_height(self) -> float:
        """Height of the tube [m]."""
        return self.fill_height + 0.02

    @property
    def lift_s(self) -> float:
        """Duration of the lift until the tube clears the pile [s]."""
        return (self.cylinder_height + 0.01) / self.lift_speed

    def params(self) -> SimParams:
        """Sand (0), steel base (1), steel cylinder (2): Tables 2 and 6 of the paper."""
        sand = Material('sand', self.density, 1.7e6, 0.25)
        steel = Material('steel', 7800.0, 2.1e11, 0.3)
        pp = Interaction(0.3, 0.71, 0.59, 0.26)
        pb = Interaction(0.3, 0.40, 0.30, 0.26)
        return SimParams(materials=(sand, steel, steel),
                         interactions={(0, 0): pp, (0, 1): pb, (0, 2): pb},
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


@dataclass(frozen=True)
class ReposeResult:
    """Angles of one pile: engine, from the base [deg], from the top [deg], pile height [m],
    profile radii (k,) [m] and heights (k,) [m]."""

    engine: str
    base_deg: float
    top_deg: float
    height: float
    r: F64
    h: F64


def pile_profile(pos: F64, radii: F64, ring: float, sectors: int = 8) -> tuple[F64, F64]:
    """Surface profile: ring centres (k,) [m] and mean over sectors of the highest top [m]."""
    rr = np.hypot(pos[:, 0], pos[:, 2])
    sec = ((np.arctan2(pos[:, 2], pos[:, 0]) + math.pi) / (2 * math.pi) * sectors).astype(int)
    sec = np.clip(sec, 0, sectors - 1)
    k = (rr / ring).astype(int)
    n_ring = int(k.max()) + 1
    tops = np.zeros((sectors, n_ring))
    np.maximum.at(tops, (sec, k), pos[:, 1] + radii)
    centres = np.asarray((np.arange(n_ring) + 0.5) * ring, dtype=np.float64)
    return centres, np.asarray(tops.mean(axis=0), dtype=np.float64)


def repose_angles(engine: str, pos: F64, radii: F64) -> ReposeResult:
    """Angles from the base and from the top of the pile profile (see the module docstring)."""
    on_base = pos[:, 1] < 0.5  # the whole pile; nothing is left in the lifted tube
    r, h = pile_profile(pos[on_base], radii[on_base], float(2 * radii.mean()))
    peak = float(h[:3].max())
    after = np.arange(len(h)) >= int(np.argmax(h[:3]))

    def angle(lo: float, hi: float) -> float:
        sel = after & (h >= lo * peak) & (h <= hi * peak)
        if sel.sum() < 2:
            return math.nan
        return math.degrees(math.atan(-np.polyfit(r[sel], h[sel], 1)[0]))

    return ReposeResult(engine, angle(0.1, 0.6), angle(0.4, 0.9), peak, r, h)


def repose_dempath(case: ReposeCase) -> ReposeResult:
    """Fill, settle, lift and measure on the dempath engine."""
    from dempath_sim.engine import Engine, ToolPose
    from dempath_sim.mesh import TriangleMesh
    from dempath_sim.state import SimState
    from dempath_sim.walls import Plane

    params = case.params()
    pos, radii = case.particles()
    state = SimState.from_spheres(pos, radii, 0, params)
    engine = Engine(params, [Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 1)],
                    TriangleMesh(case.tube(), material=2, name='tube'))
    engine.bind(state)
    dt = float(engine.dt or 0.0)
    state = engine.run(state, int(case.settle_s / dt))
    t0, v = state.time, case.lift_speed

    def lift(t: float) -> ToolPose:
        up = min(max(t - t0, 0.0), case.lift_s)
        moving = v if t - t0 < case.lift_s else 0.0
        return ToolPose(np.array([0.0, v * up, 0.0]), np.array([0.0, moving, 0.0]))

    state = engine.run(state, int((case.lift_s + case.rest_s) / dt), tool_motion=lift)
    return repose_angles('dempath', state.positions, state.radii)


def repose_liggghts(case: ReposeCase, workdir: Path, dt: float, nprocs: int = 1,
                    friction: str = 'static') -> ReposeResult:
    """The same discharge on LIGGGHTS with time step ``dt`` [s]."""
    params = case.params()
    pos, radii = case.particles()
    workdir.mkdir(parents=True, exist_ok=True)
    cmd.write_ascii_stl(str(workdir / 'tube.stl'), case.tube().tolist(), 'tube')
    big = 0.3
    lines = cmd.header((-big, -0.01, -big), (big, 2 * case.cylinder_height + 0.05, big), 3,
                       0.5 * case.particle_diameter, True)
    lines += ['hard_particles yes', *cmd.materials(params, friction), *cmd.pair_style(params),
              *cmd.gravity(params), f'timestep {cmd.fmt(dt)}',
              cmd.plane_wall('base', params, 'y', 0.0, 1),
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
    (workdir / 'in.repose').write_text('\n'.join(lines) + '\n')
    run_deck(workdir / 'in.repose', nprocs=nprocs)
    frame = read_dump(workdir / 'pile.dump')[-1]
    xyz = frame.data[:, 1:4]
    return repose_angles('liggghts', xyz, frame.column('radius'))
