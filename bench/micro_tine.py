"""Micro-scenes of the leaning-tine bin on both engines: a few grains, seconds per run.

Each scene puts a handful of grains (or a small bed read from one LIGGGHTS data file) on the
deck's floor, with the deck's physics (``leaning_tine.yaml`` on dempath, the deck's
``physics_base.in`` on LIGGGHTS 3.8), and moves the deck's tine (``tine.stl``) at a constant
velocity; both engines record the grains and the tine force every ``every`` steps. The scenes
isolate what the same-bed pass of the leaning-tine bin cannot: a grain meeting the tine's front
face, its side edge or its tip; a grain sliding or rolling along a wall; an oblique impact on
the tine face; a small bed pushed by the tine.

    .venv/bin/python bench/micro_tine.py [--scenes edge,wall,impact,drop,bed] [--work DIR]
    .venv/bin/python bench/micro_tine.py --deck raked_tine [--scenes edge,bed,bed_laws]

``--deck raked_tine`` takes the second hand-written deck (issue 29: a 35 mm bar leaning 25 deg,
7 / 8 mm grains of 2600 kg/m^3, floor at -0.12 m). ``bed_laws`` pushes the small bed with the
deck's tine on LIGGGHTS and on dempath twice: with LIGGGHTS 3.8's contact law
(``same_physics``) and with the scene file's own law (for ``raked_tine.yaml`` dempath's
default forms), to show which law choice moves the grains beside the tine.

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
from dempath_sim.engine.laws.dispatch import TAB_FORMS, TAB_SPRING
from dempath_sim.runs import PARTICLES, TOOL, WALLS, build_params
from dempath_sim.runs.markers import select_markers
from dempath_sim.scene.spec import MARKER_PICKS, MarkerSpec
from dempath_sim.validation.cross_engine import same_physics
from dempath_sim.validation.deck_setup import (
    LEANING_TINE,
    RAKED_TINE,
    SIDE_X,
    Deck,
    read_data,
    read_dump,
    scene_for,
)

F64 = NDArray[np.float64]
DT = 5e-5  # s


@dataclass(frozen=True)
class MicroDeck:
    """What a micro-scene takes from its deck: the deck, its grains' density [kg/m^3] and
    radii [m], its floor [m] and the lateral offsets [m] of the edge scene."""

    deck: Deck
    density: float
    radii: tuple[float, ...]
    floor_y: float
    edge_offsets: tuple[float, ...]


MICRO_DECKS = {
    'leaning_tine': MicroDeck(LEANING_TINE, 1734.0, (0.00405, 0.0045, 0.00495), -0.10,
                              (0.0, 0.010, 0.018, 0.022, 0.025, 0.027, 0.029, 0.031)),
    'raked_tine': MicroDeck(RAKED_TINE, 2600.0, (0.0035, 0.0040), -0.12,
                            (0.0, 0.010, 0.015, 0.0175, 0.020, 0.022)),
}
MICRO = MICRO_DECKS['leaning_tine']  # the deck of this run (main's --deck)
FLOOR_Y = MICRO.floor_y
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
    law: str = 'liggghts'  # dempath's contact law: 'liggghts' (same_physics) or 'scene'
    # Per material pair (a, b): {'spring': 0/1, 'forms': 0/1}, LIGGGHTS' Coulomb limit and
    # forms switched on that pair alone (dempath's pair table columns TAB_SPRING, TAB_FORMS).
    pair_law: dict[tuple[int, int], dict[str, float]] = field(default_factory=dict)
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
    """The scene on dempath's engine with the deck scene's physics (and LIGGGHTS 3.8's
    contact law unless ``sc.law`` is 'scene')."""
    scene = scene_for(sc.variant, scene_file=MICRO.deck.scene_file())
    if sc.law == 'liggghts':
        scene = same_physics(scene)
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
    mesh = None if sc.tip is None else TriangleMesh.from_stl(MICRO.deck.folder / 'tine.stl',
                                                             material=TOOL)
    engine = Engine(params, planes, mesh)
    for (a, b), cols in sc.pair_law.items():  # one factor at a time: the engine's pair table
        for name, value in cols.items():
            col = {'spring': TAB_SPRING, 'forms': TAB_FORMS}[name]
            engine._tab[a, b, col] = engine._tab[b, a, col] = value
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
             '-0.16 0.16 xlo xhi', f'{FLOOR_Y - 0.01:.12g} 0.25 ylo yhi',
             '-0.06 0.56 zlo zhi', '', 'Atoms', '']
    lines += [f'{i + 1} 1 {2 * r:.12g} {MICRO.density} {x:.12g} {y:.12g} {z:.12g}'
              for i, (r, (x, y, z)) in enumerate(zip(sc.radii, sc.positions, strict=True))]
    lines += ['', 'Velocities', '']
    lines += [f'{i + 1} ' + ' '.join(f'{v:.12g}' for v in (*vel[i], *omg[i])) for i in range(n)]
    path.write_text('\n'.join(lines) + '\n')


def deck_text(sc: Scene) -> str:
    """The LIGGGHTS 3.8 input of the scene (the deck's pieces)."""
    d = MICRO.deck.folder
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
                    str(MICRO.deck.folder), '-in', 'in.micro'], cwd=work, check=True,
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


def one_grain(x0: float, z0: float = 0.10, r: float | None = None, **kw: Any) -> Scene:
    """One grain (the deck's largest unless r [m] is given) resting on the floor at lateral
    offset x0, the tine 40 mm behind it."""
    r = MICRO.radii[-1] if r is None else r
    return Scene(np.array([[x0, FLOOR_Y + r, z0]]), np.array([r]), **kw,
                 tip=(0.0, FLOOR_Y + 0.002, z0 - 0.04))


def scene_edge(work: Path) -> dict[str, Any]:
    """One grain met by the tine at lateral offsets across its front face, side edge and beyond:
    the grain's lateral exit (x - x0) and velocity, its forward travel, the peak tine force."""
    out: dict[str, Any] = {}
    for x0 in MICRO.edge_offsets:
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


def small_bed(nx: int = 6, ny: int = 8, nz: int = 6, seed: int = 1,
              z_centre: float = 0.2, spacing: float = 0.010) -> tuple[F64, F64]:
    """Grains of the deck's sizes in equal numbers on a jittered lattice (``spacing`` [m])
    above the floor, centred on X = 0, Z = z_centre [m]: (positions (n, 3), radii (n,))."""
    rng = np.random.default_rng(seed)
    g = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing='ij'), -1)
    pos = g.reshape(-1, 3) * spacing + np.array([-(nx - 1) * spacing / 2, FLOOR_Y + 0.006,
                                                 z_centre - (nz - 1) * spacing / 2])
    jitter = (spacing - 2 * max(MICRO.radii)) / 2 - 1e-5
    pos += rng.uniform(-jitter, jitter, pos.shape)
    return pos, rng.choice(MICRO.radii, len(pos))


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


LAW_SEEDS = [1, 2, 3, 4]  # beds of the law scenes (main's --law-seeds)


@dataclass(frozen=True)
class LawBed:
    """A bed of the law scenes: lattice (nx, ny, nz) centred on Z = z_centre [m], side walls at
    +-half_width [m], end walls z_walls [m], settle and push steps, the tine's start Z [m] and
    the side grains' least start Z [m]."""

    name: str
    lattice: tuple[int, int, int]
    z_centre: float
    half_width: float
    z_walls: tuple[float, float]
    settle_steps: int
    push_steps: int
    tip_z: float
    side_from_z: float
    spacing: float = 0.010  # m, lattice spacing
    tip_y: float = 0.012  # m, the tine's tip above the floor
    poured: bool = False  # the bed settles around the standing tine (the grains it overlaps
    # removed first), as the deck's; else the tine starts outside the bed's back wall


LAW_BEDS = {
    # 1,008 grains, 140 mm wide, ~35 mm deep; the tine 12 mm above the floor, pushed 100 mm.
    'micro': LawBed('laws', (14, 8, 9), 0.2, 0.075, (0.150, 0.300), 4000, 2000, 0.14, 0.20),
    # 6,160 grains, 200 mm wide, ~75 mm deep, 130 mm long; pushed 150 mm.
    'mid': LawBed('mid', (20, 22, 14), 0.25, 0.10, (0.175, 0.420), 6000, 3000, 0.15, 0.22),
    # ~15,000 grains, 200 x 250 mm, ~120 mm deep, poured around the tine standing with its tip
    # 40 mm above the floor at Z = 0.10 m (80 mm deep, as the deck's); pushed 100 mm.
    'poured': LawBed('poured', (23, 23, 29), 0.125, 0.10, (0.0, 0.25), 7000, 2000, 0.10, 0.14,
                     spacing=0.0085, tip_y=0.040, poured=True),
}


def _outside_tine(pos: F64, rad: F64, tip: tuple[float, float, float]) -> NDArray[np.bool_]:
    """Grains that do not overlap the deck's tine standing at ``tip`` (its bar: width, height,
    thickness and lean read from the deck's STL)."""
    v = np.array([[float(w) for w in line.split()[1:]]
                  for line in (MICRO.deck.folder / 'tine.stl').read_text().splitlines()
                  if line.strip().startswith('vertex')])
    rel = pos - np.array(tip)
    height = float(v[:, 1].max())
    lean = -float(v[v[:, 1] == height, 2].max()) / height  # tan of the lean from vertical
    normal = np.array([0.0, lean, 1.0]) / math.hypot(lean, 1.0)  # the front face's
    thick = -float(v[np.abs(v[:, 1]) < 1e-12, 2].min()) * normal[2]
    inside = ((np.abs(rel[:, 0]) < float(v[:, 0].max()) + rad) & (rel[:, 1] > -rad)
              & (rel[:, 1] < height + rad) & (rel @ normal < rad)
              & (rel @ normal > -(thick + rad)))
    return ~inside


def _laws_bed(work: Path, seed: int = 1, size: LawBed = LAW_BEDS['micro']
              ) -> tuple[dict[str, F64], dict[str, Any], float]:
    """The bed of the law scenes for a lattice seed (settled once on LIGGGHTS, cached in
    ``work``), the push's scene keywords and the bed's top [m]."""
    pos, rad = small_bed(*size.lattice, seed=seed, z_centre=size.z_centre,
                         spacing=size.spacing)
    settled = work / (f'{size.name}_settle' if seed == 1 else f'{size.name}_settle_s{seed}')
    walls = [('y', FLOOR_Y, 1.0), ('x', -size.half_width, 1.0), ('x', size.half_width, -1.0),
             ('z', size.z_walls[0], 1.0), ('z', size.z_walls[1], -1.0)]
    tip = (0.0, FLOOR_Y + size.tip_y, size.tip_z)
    if not (settled / 'bed.data').exists():
        keep = _outside_tine(pos, rad, tip) if size.poured else np.ones(len(rad), bool)
        settle = Scene(pos[keep], rad[keep], walls=walls, tip=tip if size.poured else None,
                       tine_velocity=(0.0, 0.0, 0.0), steps=size.settle_steps,
                       every=size.settle_steps, write_bed=True)
        run_liggghts(settle, settled)
    bed = read_data(settled / 'bed.data')
    tops = bed['positions'][:, 1] + bed['radii']  # (grains resting on the tine's top face
    top = float(np.percentile(tops, 99) if size.poured else tops.max())  # are left out)
    push = {'walls': walls if size.poured else [*walls[:3], walls[4]], 'tip': tip,
            'steps': size.push_steps, 'every': 100, 'velocities': bed['velocities'],
            'omegas': bed['omegas'], 'params_over': {'skin': LIGGGHTS_SKIN / float(rad.min())}}
    return bed, push, top


def _side_motion(bed: dict[str, F64], top: float, traces: dict[str, Trace],
                 from_z: float = 0.20) -> dict[str, Any]:
    """Outward and forward motion [mm] of the top grains beside the tine (centres 10-40 mm
    outside its side faces, ahead of Z = from_z [m]) and the mean draft [N], per trace."""
    half = float(np.max(np.abs(np.array(read_stl_x(MICRO.deck.folder / 'tine.stl')))))
    x0 = np.abs(bed['positions'][:, 0])
    pick = (x0 > half + 0.010) & (x0 < half + 0.040) & (bed['positions'][:, 1] > top - 0.015)
    pick &= bed['positions'][:, 2] > from_z
    out: dict[str, Any] = {'n': len(bed['radii']), 'bed_top_mm': round((top - FLOOR_Y) * 1e3, 1),
                           'side_grains': int(pick.sum())}
    for name, tr in traces.items():
        sign = np.sign(tr.positions[0, pick, 0])
        dx = sign * (tr.positions[-1, pick, 0] - tr.positions[0, pick, 0])
        dz = tr.positions[-1, pick, 2] - tr.positions[0, pick, 2]
        out[name] = {'outward_mm': round(float(dx.mean()) * 1e3, 2),
                     'forward_mm': round(float(dz.mean()) * 1e3, 2),
                     'draft_n': round(float(-tr.force[1:, 2].mean()), 3)}
    return out


def _over_seeds(per_seed: dict[int, dict[str, Any]]) -> dict[str, Any]:
    """Per-seed figures and, per trace, the mean and SD over the seeds of each figure."""
    names = [k for k, v in next(iter(per_seed.values())).items() if isinstance(v, dict)]
    out: dict[str, Any] = {'seeds': per_seed}
    for name in names:
        out[name] = {}
        for fig in ('outward_mm', 'forward_mm', 'draft_n'):
            vals = np.array([r[name][fig] for r in per_seed.values()])
            out[name][fig] = round(float(vals.mean()), 3)
            out[name][fig + '_sd'] = round(float(vals.std(ddof=1)), 3) if len(vals) > 1 else 0.0
    return out


def _bed_laws(work: Path, size: LawBed) -> dict[str, Any]:
    """The law scene on beds of one size (LAW_SEEDS), see scene_bed_laws."""
    per_seed = {}
    for seed in LAW_SEEDS:
        bed, push, top = _laws_bed(work, seed, size)
        name = f'{size.name}_push' if seed == 1 else f'{size.name}_push_s{seed}'
        traces = {
            'liggghts': run_liggghts(Scene(bed['positions'], bed['radii'], **push), work / name),
            'dempath_liggghts_law': run_dempath(Scene(bed['positions'], bed['radii'], **push)),
            'dempath_scene_law': run_dempath(Scene(bed['positions'], bed['radii'], **push,
                                                   law='scene'))}
        per_seed[seed] = _side_motion(bed, top, traces, size.side_from_z)
    return _over_seeds(per_seed)


def scene_bed_laws(work: Path) -> dict[str, Any]:
    """Beds of 1,008 grains (14 x 8 x 9 on the lattice, 140 mm wide, LAW_SEEDS) settled on
    LIGGGHTS, then pushed 100 mm by the tine, its side edges inside the bed, on LIGGGHTS and on
    dempath with LIGGGHTS' contact law and with the scene's own: the outward and forward motion
    of the top grains beside the tine, per seed and mean per engine and law."""
    return _bed_laws(work, LAW_BEDS['micro'])


def scene_poured_laws(work: Path) -> dict[str, Any]:
    """The same on beds of ~15,000 grains (200 x 250 mm, ~120 mm deep) poured around the
    standing tine (80 mm deep) as the deck's bin is, pushed 100 mm from rest."""
    return _bed_laws(work, LAW_BEDS['poured'])


def scene_mid_laws(work: Path) -> dict[str, Any]:
    """The same on beds of 6,160 grains (200 mm wide, ~75 mm deep, the tine's tip ~60 mm below
    the surface), pushed 150 mm."""
    return _bed_laws(work, LAW_BEDS['mid'])


# One factor of LIGGGHTS' law at a time on dempath's default law, per material pair: grains
# with each other (PARTICLES, PARTICLES), with the bin (PARTICLES, WALLS), with the tine
# (PARTICLES, TOOL); 'spring': the Coulomb limit on the spring alone, 'forms': LIGGGHTS' forms
# (a pair's springs kept across a separation, the spring's normal part dropped; at a boundary
# the lever arm r - delta/2 and a mesh spring carried to coplanar faces only).
FACTORS: dict[str, dict[tuple[int, int], dict[str, float]]] = {
    'pairs_spring': {(PARTICLES, PARTICLES): {'spring': 1.0}},
    'pairs_forms': {(PARTICLES, PARTICLES): {'forms': 1.0}},
    'pairs_both': {(PARTICLES, PARTICLES): {'spring': 1.0, 'forms': 1.0}},
    'boundary_both': {(PARTICLES, WALLS): {'spring': 1.0, 'forms': 1.0},
                      (PARTICLES, TOOL): {'spring': 1.0, 'forms': 1.0}},
    'walls_both': {(PARTICLES, WALLS): {'spring': 1.0, 'forms': 1.0}},
    'tool_spring': {(PARTICLES, TOOL): {'spring': 1.0}},
    'tool_forms': {(PARTICLES, TOOL): {'forms': 1.0}},
    'chaos': {},  # the default law again with a 5 % larger skin: the runs' own chaos
}
CHAOS_SKIN = 1.05
FACTOR_RUNS = list(FACTORS)  # the factors bed_factors runs (main's --factors)


def scene_bed_factors(work: Path) -> dict[str, Any]:
    """The law scenes' beds pushed on dempath with its default law and one factor of LIGGGHTS'
    law switched on (FACTORS): which factor moves the grains beside the tine."""
    per_seed = {}
    for seed in LAW_SEEDS:
        bed, push, top = _laws_bed(work, seed)
        traces = {}
        for name, pl in FACTORS.items():
            if name not in FACTOR_RUNS:
                continue
            kw = dict(push)
            if name == 'chaos':
                kw['params_over'] = {'skin': push['params_over']['skin'] * CHAOS_SKIN}
            traces[name] = run_dempath(Scene(bed['positions'], bed['radii'], **kw, law='scene',
                                             pair_law=pl))
        per_seed[seed] = _side_motion(bed, top, traces)
    return _over_seeds(per_seed)


RULE_Z = (0.10, 0.12, 0.14, 0.16)  # m, marker grid points beside the tine's path (poured beds)


def _marker_rules(run: Path) -> dict[str, Any]:
    """On one LIGGGHTS push of a poured bed (its dump of every grain): the outward motion of the
    grains 40-60 mm beside the axis per 3 mm of depth below the local surface (highest top
    within 15 mm), and of the markers at X = +-50 mm, Z = RULE_Z picked by each
    ``MarkerSpec.pick`` rule (their forward motion and mean depth too)."""
    frames = read_dump(run / 'micro.dump')
    data = read_data(run / 'micro.data')
    (_, first), (_, last) = frames[0], frames[-1]
    ids = np.asarray(first['id'], np.int64)
    p0 = np.stack([first['x'], first['y'], first['z']], 1)
    where = {int(i): k for k, i in enumerate(last['id'])}
    p1 = np.stack([last['x'], last['y'], last['z']], 1)[[where[int(i)] for i in ids]]
    rad = data['radii'][np.searchsorted(data['ids'], ids)]
    tops = p0[:, 1] + rad
    depth = np.array([tops[np.hypot(p0[:, 0] - p[0], p0[:, 2] - p[2]) < 0.015].max() - t
                      for p, t in zip(p0, tops, strict=True)])
    outward = np.sign(p0[:, 0]) * (p1[:, 0] - p0[:, 0])
    side = ((np.abs(p0[:, 0]) > 0.04) & (np.abs(p0[:, 0]) < 0.06)
            & (p0[:, 2] > RULE_Z[0] - 0.01) & (p0[:, 2] < RULE_Z[-1] + 0.01))
    out: dict[str, Any] = {'depth_mm': [], 'outward_mm': [], 'grains': []}
    for lo in np.arange(0.0, 0.024, 0.003):
        band = side & (depth >= lo) & (depth < lo + 0.003)
        out['depth_mm'].append(round(float(lo) * 1e3, 1))
        out['outward_mm'].append(round(float(outward[band].mean()) * 1e3, 2))
        out['grains'].append(int(band.sum()))
    for pick in MARKER_PICKS:
        chosen = np.concatenate([
            select_markers(p0, rad, ids, MarkerSpec(
                rows=1, columns=len(RULE_Z), x_m=x, first_z_m=RULE_Z[0],
                spacing_z_m=RULE_Z[1] - RULE_Z[0], pick=pick)).particle_ids
            for x in (-SIDE_X, SIDE_X)])
        k = np.searchsorted(ids, chosen, sorter=np.argsort(ids))
        k = np.argsort(ids)[k]
        out[pick] = {'outward_mm': round(float(outward[k].mean()) * 1e3, 2),
                     'forward_mm': round(float((p1[k, 2] - p0[k, 2]).mean()) * 1e3, 2),
                     'depth_mm': round(float(depth[k].mean()) * 1e3, 2)}
    return out


def scene_marker_rules(work: Path) -> dict[str, Any]:
    """The marker rules on the LIGGGHTS pushes of the poured beds that ``poured_laws`` left in
    ``work`` (LAW_SEEDS): how much a grain's depth and the rule that picks it change the side
    markers' outward motion, on the same trajectories."""
    size = LAW_BEDS['poured']
    per_seed = {}
    for seed in LAW_SEEDS:
        run = work / (f'{size.name}_push' if seed == 1 else f'{size.name}_push_s{seed}')
        if (run / 'micro.dump').exists():
            per_seed[seed] = _marker_rules(run)
    out: dict[str, Any] = {'seeds': per_seed}
    for pick in MARKER_PICKS:
        out[pick] = {k: round(float(np.mean([r[pick][k] for r in per_seed.values()])), 2)
                     for k in ('outward_mm', 'forward_mm', 'depth_mm')}
    return out


def read_stl_x(path: Path) -> list[float]:
    """X of every vertex of an ASCII STL [m]."""
    return [float(line.split()[1]) for line in path.read_text().splitlines()
            if line.strip().startswith('vertex')]


SCENES = {'edge': scene_edge, 'wall': scene_wall, 'impact': scene_impact, 'drop': scene_drop,
          'bed': scene_bed, 'bed_laws': scene_bed_laws,
          'bed_factors': scene_bed_factors, 'mid_laws': scene_mid_laws,
          'poured_laws': scene_poured_laws, 'marker_rules': scene_marker_rules}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the chosen micro-scenes; print one JSON line of figures last."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--scenes', default=','.join(SCENES))
    ap.add_argument('--work', type=Path, default=None)
    ap.add_argument('--deck', choices=sorted(MICRO_DECKS), default='leaning_tine')
    ap.add_argument('--law-seeds', default='1,2,3,4', help='beds of the law scenes')
    ap.add_argument('--factors', default='', help=f'bed_factors: among {", ".join(FACTORS)}')
    args = ap.parse_args(argv)
    LAW_SEEDS[:] = [int(k) for k in args.law_seeds.split(',')]
    if args.factors:
        FACTOR_RUNS[:] = args.factors.split(',')
    global MICRO, FLOOR_Y  # the run's deck for every scene of this script
    MICRO = MICRO_DECKS[args.deck]
    FLOOR_Y = MICRO.floor_y
    work = args.work or Path(tempfile.mkdtemp(prefix='micro_tine_'))
    out: dict[str, Any] = {}
    for name in args.scenes.split(','):
        out[name] = SCENES[name](work)
        print(name, json.dumps(out[name]), flush=True)
    print(json.dumps({'bench': 'micro_tine', 'scenes': out}))
    return out


if __name__ == '__main__':
    main()
