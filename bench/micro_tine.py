"""Micro-scenes of the leaning-tine bin on both engines: a few grains, seconds per run.

Each scene puts a handful of grains (or a small bed read from one LIGGGHTS data file) on the
deck's floor, with the deck's physics (``leaning_tine.yaml`` on dempath, the deck's
``physics_base.in`` on LIGGGHTS 3.8), and moves the deck's tine (``tine.stl``) at a constant
velocity; both engines record the grains and the tine force every ``every`` steps. The scenes
isolate what the same-bed pass of the leaning-tine bin cannot: a grain meeting the tine's front
face, its side edge or its tip; a grain sliding or rolling along a wall; an oblique impact on
the tine face; a small bed pushed by the tine.

    .venv/bin/python bench/micro_tine.py [--scenes edge,wall,impact,drop,bed] [--work DIR]

Prints per-scene lines and, last, one JSON line of figures (both engines per scene).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine import Engine, Plane, SimState, ToolPose, TriangleMesh
from dempath_sim.runs import PARTICLES, TOOL, WALLS, build_params
from dempath_sim.validation.deck_setup import DECK_DIR, read_data, read_dump, scene_for

F64 = NDArray[np.float64]
DENSITY = 1734.0  # kg/m^3, the deck's grains
DT = 5e-5  # s
FLOOR_Y = -0.10  # m, the deck's floor
LIGGGHTS_SKIN = 0.003  # m, the deck's `neighbor 0.003 bin`
# Axis-aligned walls LIGGGHTS takes as `wall/gran primitive`: (axis, coordinate, inward sign).
AXES = {'x': 0, 'y': 1, 'z': 2}


@dataclass
class Scene:
    """A micro-scene: grains, axis-aligned walls, the tine's start tip and constant velocity."""

    positions: F64
    radii: F64
    walls: list[tuple[str, float, float]] = field(default_factory=lambda: [('y', FLOOR_Y, 1.0)])
    tip: tuple[float, float, float] | None = (0.0, FLOOR_Y + 0.002, 0.0)
    tine_velocity: tuple[float, float, float] = (0.0, 0.0, 1.0)
    steps: int = 2000
    every: int = 100
    velocities: F64 | None = None
    omegas: F64 | None = None
    params_over: dict[str, Any] = field(default_factory=dict)
    variant: str = 'base'
    write_bed: bool = False  # LIGGGHTS writes bed.data at the end (settling a micro-bed)


@dataclass
class Trace:
    """Grains' positions and velocities (nt, n, 3), angular velocities, tine force (nt, 3)."""

    times: F64
    positions: F64
    velocities: F64
    omegas: F64
    force: F64


def _empty(times: F64, n: int) -> Trace:
    """A trace of n grains at the given output times, all zero."""
    nt = len(times)
    return Trace(times, np.zeros((nt, n, 3)), np.zeros((nt, n, 3)), np.zeros((nt, n, 3)),
                 np.zeros((nt, 3)))


def run_dempath(sc: Scene) -> Trace:
    """The scene on dempath's engine with the leaning-tine scene's physics."""
    scene = scene_for(sc.variant)
    params = build_params(scene, scene.physics_model())
    if sc.params_over:
        params = replace(params, **sc.params_over)
    planes = []
    for ax, c, s in sc.walls:
        p = [0.0, 0.0, 0.0]
        n = [0.0, 0.0, 0.0]
        p[AXES[ax]] = c
        n[AXES[ax]] = s
        planes.append(Plane(tuple(p), tuple(n), WALLS))  # type: ignore[arg-type]
    mesh = None if sc.tip is None else TriangleMesh.from_stl(DECK_DIR / 'tine.stl',
                                                             material=TOOL)
    engine = Engine(params, planes, mesh)
    state = SimState.from_spheres(sc.positions, sc.radii, PARTICLES, params,
                                  velocities=sc.velocities)
    if sc.omegas is not None:
        state.angular_velocities[:] = sc.omegas
    tip = np.zeros(3) if sc.tip is None else np.array(sc.tip)
    vel = np.array(sc.tine_velocity) if sc.tip is not None else np.zeros(3)

    def pose(t: float) -> ToolPose:
        return ToolPose(tip + vel * t, vel)

    engine.tool_pose = pose(0.0)
    engine.bind(state)
    nt = sc.steps // sc.every + 1
    out = _empty(np.asarray(np.arange(nt) * sc.every * DT, np.float64), state.n)
    for f in range(nt):
        if f:
            state = engine.run(state, sc.every, pose)
        order = np.argsort(state.ids)
        out.positions[f] = state.positions[order]
        out.velocities[f] = state.velocities[order]
        out.omegas[f] = state.angular_velocities[order]
        out.force[f] = engine.tool_force
    return out


def write_data(path: Path, sc: Scene) -> None:
    """The grains as a LIGGGHTS ``atom_style granular`` data file (ids from 1)."""
    n = len(sc.radii)
    vel = np.zeros((n, 3)) if sc.velocities is None else sc.velocities
    omg = np.zeros((n, 3)) if sc.omegas is None else sc.omegas
    lines = ['micro-scene of bench/micro_tine.py', '', f'{n} atoms', '3 atom types',
             '-0.16 0.16 xlo xhi', '-0.11 0.25 ylo yhi', '-0.06 0.56 zlo zhi', '', 'Atoms', '']
    lines += [f'{i + 1} 1 {2 * r:.12g} {DENSITY} {x:.12g} {y:.12g} {z:.12g}'
              for i, (r, (x, y, z)) in enumerate(zip(sc.radii, sc.positions, strict=True))]
    lines += ['', 'Velocities', '']
    lines += [f'{i + 1} ' + ' '.join(f'{v:.12g}' for v in (*vel[i], *omg[i])) for i in range(n)]
    path.write_text('\n'.join(lines) + '\n')


def deck_text(sc: Scene) -> str:
    """The LIGGGHTS 3.8 input of the scene (the leaning-tine deck's pieces)."""
    d = DECK_DIR
    out = ['atom_style granular', 'atom_modify map array', 'boundary f f f', 'newton off',
           'communicate single vel yes', 'units si', 'soft_particles yes', 'hard_particles yes',
           'read_data micro.data', 'neighbor 0.003 bin', 'neigh_modify delay 0',
           f'include {d}/physics_{sc.variant}.in'.replace('${deck}', str(d))]
    for k, (ax, c, _s) in enumerate(sc.walls):
        out.append(f'fix w{k} all wall/gran model hertz tangential history primitive type 2 '
                   f'{ax}plane {c:.12g}')
    if sc.tip is not None:
        x, y, z = sc.tip
        out += [f'fix tine all mesh/surface/stress file {d}/tine.stl type 3 move {x} {y} {z} '
                f'reference_point {x} {y} {z}',
                'fix tinewall all wall/gran model hertz tangential history mesh n_meshes 1 '
                'meshes tine',
                'fix mv all move/mesh mesh tine linear {} {} {}'.format(*sc.tine_velocity)]
    out += [f'timestep {DT}', 'fix gravi all gravity 9.81 vector 0.0 -1.0 0.0',
            'fix integr all nve/sphere',
            f'dump d all custom {sc.every} micro.dump id x y z vx vy vz omegax omegay omegaz',
            'dump_modify d sort id format "%d' + ' %.15g' * 9 + '"']
    if sc.tip is not None:
        out += ['variable fx equal f_tine[1]', 'variable fy equal f_tine[2]',
                'variable fz equal f_tine[3]',
                f'fix pr all print {sc.every} "$(step) ${{fx}} ${{fy}} ${{fz}}" file force.txt '
                'screen no']
    out += [f'run {sc.steps}']
    if sc.write_bed:
        out += ['write_data bed.data']
    return '\n'.join(out) + '\n'


def run_liggghts(sc: Scene, work: Path) -> Trace:
    """The scene on LIGGGHTS 3.8 (one process)."""
    work.mkdir(parents=True, exist_ok=True)
    write_data(work / 'micro.data', sc)
    (work / 'in.micro').write_text(deck_text(sc))
    subprocess.run(['liggghts', '-echo', 'none', '-log', 'log.micro', '-var', 'deck',
                    str(DECK_DIR), '-in', 'in.micro'], cwd=work, check=True,
                   capture_output=True)
    frames = read_dump(work / 'micro.dump')
    nt = len(frames)
    n = len(sc.radii)
    tr = _empty(np.array([s for s, _ in frames], np.float64) * DT, n)
    for f, (_, c) in enumerate(frames):
        idx = np.asarray(c['id'], int) - 1
        tr.positions[f, idx] = np.stack([c['x'], c['y'], c['z']], 1)
        tr.velocities[f, idx] = np.stack([c['vx'], c['vy'], c['vz']], 1)
        tr.omegas[f, idx] = np.stack([c['omegax'], c['omegay'], c['omegaz']], 1)
    if sc.tip is not None and (work / 'force.txt').exists():
        pr = np.loadtxt(work / 'force.txt', ndmin=2)
        for row in pr:
            f = round(row[0] / sc.every)
            if 0 <= f < nt:
                tr.force[f] = row[1:4]
    return tr


def both(sc: Scene, work: Path, name: str) -> tuple[Trace, Trace]:
    """(dempath, LIGGGHTS) traces of a scene."""
    return run_dempath(sc), run_liggghts(sc, work / name)


def one_grain(x0: float, z0: float = 0.10, r: float = 0.0045, **kw: Any) -> Scene:
    """One grain resting on the floor at lateral offset x0, the tine 40 mm behind it."""
    return Scene(np.array([[x0, FLOOR_Y + r, z0]]), np.array([r]), **kw,
                 tip=(0.0, FLOOR_Y + 0.002, z0 - 0.04))


def scene_edge(work: Path) -> dict[str, Any]:
    """One grain met by the tine at lateral offsets across its front face, side edge and beyond:
    the grain's lateral exit (x - x0) and velocity, its forward travel, the peak tine force."""
    out: dict[str, Any] = {}
    for x0 in (0.0, 0.010, 0.018, 0.022, 0.025, 0.027, 0.029, 0.031):
        res = []
        for tr in both(one_grain(x0, steps=2400), work, f'edge_{x0 * 1e3:.0f}'):
            res.append({'dx_mm': round(float(tr.positions[-1, 0, 0] - x0) * 1e3, 3),
                        'vx': round(float(tr.velocities[-1, 0, 0]), 4),
                        'dz_mm': round(float(tr.positions[-1, 0, 2] - 0.10) * 1e3, 2),
                        'y_mm': round(float(tr.positions[-1, 0, 1] - FLOOR_Y) * 1e3, 2),
                        'fz_peak': round(float(np.abs(tr.force[:, 2]).max()), 4)})
        out[f'{x0 * 1e3:.0f}mm'] = {'dempath': res[0], 'liggghts': res[1]}
    return out


def _max_dev(a: Trace, b: Trace) -> dict[str, float]:
    """Largest differences of two traces: position [mm], velocity [m/s], spin [rad/s]."""
    return {'pos_mm': round(float(np.abs(a.positions - b.positions).max()) * 1e3, 4),
            'vel': round(float(np.abs(a.velocities - b.velocities).max()), 5),
            'omega': round(float(np.abs(a.omegas - b.omegas).max()), 3),
            'force': round(float(np.abs(a.force - b.force).max()), 5)}


def scene_wall(work: Path) -> dict[str, Any]:
    """A grain thrown along the floor into a side wall (sliding, then rolling along both), and a
    spinning grain dropped against the side wall: trajectories of both engines compared."""
    r = 0.0045
    walls = [('y', FLOOR_Y, 1.0), ('x', 0.15, -1.0)]
    thrown = Scene(np.array([[0.13, FLOOR_Y + r, 0.2]]), np.array([r]), walls=walls, tip=None,
                   velocities=np.array([[0.4, 0.0, 0.8]]), steps=4000)
    spun = Scene(np.array([[0.15 - r * 0.98, FLOOR_Y + 0.03, 0.2]]), np.array([r]),
                 walls=walls, tip=None, velocities=np.array([[0.3, -0.5, 0.2]]),
                 omegas=np.array([[20.0, -40.0, 60.0]]), steps=3000)
    out: dict[str, Any] = {}
    for name, sc in (('thrown', thrown), ('spun', spun)):
        d, g = both(sc, work, f'wall_{name}')
        out[name] = {'max_dev': _max_dev(d, g),
                     'end_dempath': [round(float(v) * 1e3, 3) for v in d.positions[-1, 0]],
                     'end_liggghts': [round(float(v) * 1e3, 3) for v in g.positions[-1, 0]]}
    return out


def scene_impact(work: Path) -> dict[str, Any]:
    """Grains thrown obliquely, with spin, at the standing tine's front face, its side edge and
    its side face; and two grains colliding obliquely: trajectories compared."""
    r = 0.0045
    tip = (0.0, FLOOR_Y + 0.05, 0.10)
    # The front face at height h above the tip is at z = tip_z - h / tan(60 deg).
    h = 0.04
    zf = tip[2] - h / math.tan(math.radians(60.0))
    cases = {
        'face': ([0.0, tip[1] + h, zf + 0.012], [0.2, -0.3, -1.0]),
        'edge': ([0.027, tip[1] + h, zf + 0.010], [0.1, -0.3, -1.0]),
        'side': ([0.040, tip[1] + h, zf - 0.020], [-1.0, -0.2, 0.3]),
    }
    out: dict[str, Any] = {}
    for name, (p, v) in cases.items():
        sc = Scene(np.array([p]), np.array([r]), tip=tip, tine_velocity=(0.0, 0.0, 0.0),
                   velocities=np.array([v]), omegas=np.array([[30.0, -20.0, 10.0]]),
                   steps=600, every=20)
        d, g = both(sc, work, f'impact_{name}')
        out[name] = {'max_dev': _max_dev(d, g),
                     'v_end_dempath': [round(float(x), 4) for x in d.velocities[-1, 0]],
                     'v_end_liggghts': [round(float(x), 4) for x in g.velocities[-1, 0]]}
    pair = Scene(np.array([[0.0, 0.0, 0.2], [0.003, 0.002, 0.2095]]), np.array([r, 0.004]),
                 walls=[], tip=None, velocities=np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -0.5]]),
                 omegas=np.array([[10.0, 0.0, 0.0], [0.0, -30.0, 0.0]]), steps=300, every=10)
    d, g = both(pair, work, 'impact_pair')
    out['pair'] = {'max_dev': _max_dev(d, g)}
    return out


def small_bed(nx: int = 6, ny: int = 8, nz: int = 6, seed: int = 1) -> tuple[F64, F64]:
    """Grains of 8.1 / 9.0 / 9.9 mm on a jittered 10 mm lattice above the floor, centred on
    X = 0, Z = 0.2 m: (positions (n, 3), radii (n,))."""
    rng = np.random.default_rng(seed)
    g = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing='ij'), -1)
    pos = g.reshape(-1, 3) * 0.010 + np.array([-(nx - 1) * 0.005, FLOOR_Y + 0.006,
                                               0.2 - (nz - 1) * 0.005])
    pos += rng.uniform(-0.0004, 0.0004, pos.shape)
    return pos, rng.choice([0.00405, 0.0045, 0.00495], len(pos))


def divergence(d: Trace, g: Trace) -> list[float]:
    """log10 of the largest grain position difference [m] of the two engines per output."""
    dev = np.abs(d.positions - g.positions).max(axis=(1, 2))
    return [round(float(np.log10(max(v, 1e-18))), 2) for v in dev]


def scene_drop(work: Path) -> dict[str, Any]:
    """288 grains dropped into a 70 mm box and settling (no tine): how fast the two engines'
    trajectories part (a contact-bookkeeping fault shows as a jump, chaos as a steady growth)."""
    pos, rad = small_bed()
    walls = [('y', FLOOR_Y, 1.0), ('x', -0.035, 1.0), ('x', 0.035, -1.0), ('z', 0.165, 1.0),
             ('z', 0.235, -1.0)]
    sc = Scene(pos, rad, walls=walls, tip=None, steps=3000, every=50,
               params_over={'skin': LIGGGHTS_SKIN / float(rad.min())})
    d, g = both(sc, work, 'drop')
    return {'log10_dev_m': divergence(d, g), 'every_s': 50 * DT}


def first_parting(d: Trace, g: Trace, tol: float = 1e-7) -> tuple[int, int]:
    """(output, grain) where the two engines' velocities first differ by more than tol [m/s];
    (-1, -1) if never."""
    dv = np.abs(d.velocities - g.velocities).max(axis=2)
    hit = np.argwhere(dv > tol)
    return (int(hit[0, 0]), int(hit[0, 1])) if len(hit) else (-1, -1)


def scene_bed(work: Path) -> dict[str, Any]:
    """A bed of 360 grains settled on LIGGGHTS (its data file read by both engines, as the
    same-bed runs do), then pushed by the tine with both side edges inside the bed: how long
    the two engines' trajectories agree, where they part first (the grain and its distance to
    the tine) and the side grains' outward motion."""
    pos, rad = small_bed(nx=10, ny=6, nz=6)
    skin = {'skin': LIGGGHTS_SKIN / float(rad.min())}
    walls = [('y', FLOOR_Y, 1.0), ('x', -0.055, 1.0), ('x', 0.055, -1.0), ('z', 0.165, 1.0),
             ('z', 0.30, -1.0)]
    settle = Scene(pos, rad, walls=walls, tip=None, steps=4000, every=4000, write_bed=True)
    run_liggghts(settle, work / 'bed_settle')
    bed = read_data(work / 'bed_settle' / 'bed.data')
    top = float((bed['positions'][:, 1] + bed['radii']).max())
    push = Scene(bed['positions'], bed['radii'], walls=[*walls[:3], walls[4]],
                 tip=(0.0, FLOOR_Y + 0.012, 0.15), steps=1400, every=10,
                 velocities=bed['velocities'], omegas=bed['omegas'], params_over=skin)
    d, g = both(push, work, 'bed_push')
    f, i = first_parting(d, g)
    side = np.abs(bed['positions'][:, 0]) > 0.03
    near_top = bed['positions'][:, 1] > top - 0.012
    pick = side & near_top
    out = {'bed_top_mm': round((top - FLOOR_Y) * 1e3, 1), 'n': len(bed['radii']),
           'log10_dev_m': divergence(d, g)[::10], 'every_s': 10 * DT * 10,
           'first_parting_s': round(f * 10 * DT, 5) if f >= 0 else None}
    if f >= 0:
        p = d.positions[f, i]
        tip_z = 0.15 + d.times[f]
        out['first_parting_grain'] = {'x_mm': round(p[0] * 1e3, 2),
                                      'y_mm': round((p[1] - FLOOR_Y) * 1e3, 2),
                                      'z_from_tip_mm': round((p[2] - tip_z) * 1e3, 2),
                                      'r_mm': round(float(bed['radii'][i]) * 1e3, 2)}
    for name, tr in (('dempath', d), ('liggghts', g)):
        x0 = tr.positions[0, pick, 0]
        dx = np.sign(x0) * (tr.positions[-1, pick, 0] - x0)
        out[f'side_outward_mm_{name}'] = round(float(dx.mean()) * 1e3, 2)
    return out


SCENES = {'edge': scene_edge, 'wall': scene_wall, 'impact': scene_impact, 'drop': scene_drop,
          'bed': scene_bed}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the chosen micro-scenes; print one JSON line of figures last."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--scenes', default=','.join(SCENES))
    ap.add_argument('--work', type=Path, default=None)
    args = ap.parse_args(argv)
    work = args.work or Path(tempfile.mkdtemp(prefix='micro_tine_'))
    out: dict[str, Any] = {}
    for name in args.scenes.split(','):
        out[name] = SCENES[name](work)
        print(name, json.dumps(out[name]), flush=True)
    print(json.dumps({'bench': 'micro_tine', 'scenes': out}))
    return out


if __name__ == '__main__':
    main()
