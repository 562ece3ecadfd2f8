"""Where the raked-tine bin's pour puts its grains, on both engines: a strip of the bin.

Issue 29 found dempath's pour of the raked-tine bin (``raked_tine.yaml``, ``fill.count:
surface``) holding about 3.5 % more grains than the hand-written deck's for the same surface in
the central strip. A whole bed is ~50,000 grains; this bench settles a strip of the bin instead:
the full width (300 mm, both steel side walls), the full depth (floor at -0.12 m) and 100 mm of
its length between steel end walls, no tine, 0.4 s, dt 5e-5 s. Four beds of one seed:

- ``liggghts``: the deck's insertion (``insert/pack`` at solid fraction 0.35 up to 210 mm above
  the floor, the deck's 7 / 8 mm templates, 50/50 by mass) settled on LIGGGHTS 3.8 with the
  deck's ``physics_base.in``;
- ``dempath_on_insert_default`` / ``dempath_on_insert_liggghts``: that same inserted (unsettled)
  bed, read from LIGGGHTS' data file, settled on dempath with the scene's default contact law /
  LIGGGHTS' (``same_physics``): the law alone;
- ``dempath_pour_default``: dempath's own random pour (``runs.pour``) of the same number of
  grains, settled with the default law: the insertion procedure.

Figures per bed: grains, surface (``bed_measure.surface_height``, wall columns left out), the
highest grain top per 15 mm band across X (mean over Z), the share of grains whose centres lie
within 15 mm of a side wall, interior solid fraction. Runs are cached under ``--work``.

    .venv/bin/python bench/raked_pour.py [--work DIR] [--seed 1]

Last line: one JSON object.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import subprocess
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine import Engine, SimState
from dempath_sim.runs import PARTICLES, bin_walls, build_params
from dempath_sim.runs.bed_measure import measure
from dempath_sim.runs.pour import pour
from dempath_sim.scene import SceneSpec
from dempath_sim.validation.cross_engine import same_physics
from dempath_sim.validation.deck_setup import RAKED_TINE, read_data, scene_for

F64 = NDArray[np.float64]
STRIP_Z = 0.10  # m, the strip's length
SETTLE_STEPS = 8000  # 0.4 s at 5e-5 s, the deck's settle
BAND = 0.015  # m, width of the bands across X
PRIMES = {1: (15485863, 32452843), 2: (49979687, 67867967), 3: (86028121, 104395301)}


def strip_scene(seed: int) -> SceneSpec:
    """The raked-tine scene on the strip: bin 100 mm long, no density target."""
    scene = scene_for('base', seed, RAKED_TINE.scene_file())
    return replace(scene, bin=replace(scene.bin, length_z_m=STRIP_Z))


def liggghts_deck(seed: int) -> str:
    """The deck's insertion and settle on the strip (LIGGGHTS 3.8 input)."""
    p1, p2 = PRIMES[seed]
    d = RAKED_TINE.folder
    return '\n'.join([
        f'variable deck index {d}', f'include {d}/header.in',
        'region domain block -0.16 0.16 -0.13 0.14 -0.01 0.11 units box', 'create_box 3 domain',
        'neighbor 0.003 bin', 'neigh_modify delay 0', f'include {d}/physics_base.in',
        'fix floor all wall/gran model hertz tangential history primitive type 2 yplane -0.12',
        'fix wxlo all wall/gran model hertz tangential history primitive type 2 xplane -0.15',
        'fix wxhi all wall/gran model hertz tangential history primitive type 2 xplane 0.15',
        'fix wzlo all wall/gran model hertz tangential history primitive type 2 zplane 0.0',
        f'fix wzhi all wall/gran model hertz tangential history primitive type 2 zplane {STRIP_Z}',
        'timestep 5e-5', 'fix gravi all gravity 9.81 vector 0.0 -1.0 0.0',
        'fix pts1 all particletemplate/sphere 10007 atom_type 1 density constant 2600 '
        'radius constant 0.0035',
        'fix pts2 all particletemplate/sphere 10009 atom_type 1 density constant 2600 '
        'radius constant 0.0040',
        f'fix pdd all particledistribution/discrete {p2} 2 pts1 0.5 pts2 0.5',
        f'region pour block -0.15 0.15 -0.12 0.09 0.0 {STRIP_Z} units box',
        f'fix ins all insert/pack seed {p1} distributiontemplate pdd maxattempt 200 '
        'insert_every once overlapcheck yes all_in yes vel constant 0. 0. 0. '
        'region pour volumefraction_region 0.35 ntry_mc 10000',
        'fix integr all nve/sphere', 'thermo_modify lost ignore norm no', 'run 1',
        'unfix ins', 'write_data inserted.data', f'run {SETTLE_STEPS - 1}',
        'write_data bed.data']) + '\n'


def run_liggghts(work: Path, seed: int) -> Path:
    """Insert and settle the strip on LIGGGHTS (cached); the run's folder."""
    folder = work / f'liggghts_s{seed}'
    if not (folder / 'bed.data').exists():
        folder.mkdir(parents=True, exist_ok=True)
        (folder / 'in.strip').write_text(liggghts_deck(seed))
        subprocess.run(['liggghts', '-echo', 'none', '-log', 'log.strip', '-in', 'in.strip'],
                       cwd=folder, check=True, capture_output=True)
    return folder


def settle_dempath(scene: SceneSpec, state: SimState) -> SimState:
    """Settle a bed on dempath for the deck's 0.4 s with the scene's physics, no tool."""
    params = build_params(scene, scene.physics_model())
    engine = Engine(params, bin_walls(scene), None)
    engine.bind(state)
    return engine.run(state, SETTLE_STEPS)


def bed_state(scene: SceneSpec, data: dict[str, F64]) -> SimState:
    """A dempath state of a LIGGGHTS bed (positions, radii, velocities, spins)."""
    params = build_params(scene, scene.physics_model())
    state = SimState.from_spheres(data['positions'], data['radii'], PARTICLES, params,
                                  velocities=data['velocities'])
    state.angular_velocities[:] = data['omegas']
    return state


def figures(scene: SceneSpec, positions: F64, radii: F64) -> dict[str, Any]:
    """Grains, surface, per-band tops across X, the wall bands' share, interior fraction."""
    model = scene.physics_model()
    params = build_params(scene, model)
    state = SimState.from_spheres(positions, radii, PARTICLES, params)
    m = measure(scene, model, state)
    half = scene.bin.width_x_m / 2
    edges = np.arange(-half, half + 1e-9, BAND)
    tops = []
    for lo, hi in itertools.pairwise(edges):
        inb = (positions[:, 0] >= lo) & (positions[:, 0] < hi)
        zb = np.floor(positions[inb, 2] / BAND).astype(int)
        top = positions[inb, 1] + radii[inb]
        tops.append(float(np.mean([top[zb == k].max() for k in np.unique(zb)])))
    wall = np.abs(positions[:, 0]) > half - BAND
    return {'grains': len(radii), 'surface_mm': round(1e3 * m['surface_height_m'], 2),
            'solid_fraction_inside': round(m['solid_fraction'], 4),
            'wall_band_share': round(float(wall.mean()), 4),
            'band_tops_mm': [round(1e3 * t, 1) for t in tops],
            'whole_bed_fraction': round(float(np.sum(4 / 3 * math.pi * radii**3))
                                        / (2 * half * STRIP_Z * (scene.bed_thickness_m
                                                                 + m['surface_height_m'])), 4)}


def main() -> None:
    """Settle the four beds of a seed (cached) and print their figures; one JSON line last."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--work', type=Path, default=Path.home() / '.cache' / 'dempath' / 'raked_pour')
    ap.add_argument('--seed', type=int, default=1, choices=sorted(PRIMES))
    args = ap.parse_args()
    scene = strip_scene(args.seed)
    folder = run_liggghts(args.work, args.seed)
    out: dict[str, Any] = {}
    lig = read_data(folder / 'bed.data')
    out['liggghts'] = figures(scene, lig['positions'], lig['radii'])
    inserted = read_data(folder / 'inserted.data')
    def on_insert(sc: SceneSpec) -> SimState:
        return bed_state(sc, inserted)

    def own_pour(sc: SceneSpec) -> SimState:
        model = sc.physics_model()
        return pour(sc, model, build_params(sc, model), len(inserted['radii']) / _pour_count(sc))

    runs: dict[str, tuple[SceneSpec, Callable[[SceneSpec], SimState]]] = {
        'dempath_on_insert_default': (scene, on_insert),
        'dempath_on_insert_liggghts': (same_physics(scene), on_insert),
        'dempath_pour_default': (scene, own_pour)}
    for name, (sc, make) in runs.items():
        cache = args.work / f'{name}_s{args.seed}.npz'
        if not cache.exists():
            state = settle_dempath(sc, make(sc))
            np.savez(cache, positions=state.positions, radii=state.radii)
        with np.load(cache) as d:
            out[name] = figures(scene, d['positions'], d['radii'])
        print(name, json.dumps(out[name]), flush=True)
    print(json.dumps({'bench': 'raked_pour', 'seed': args.seed, 'strip_z_m': STRIP_Z,
                      'beds': out}))


def _pour_count(scene: SceneSpec) -> int:
    """Grains dempath's pour places at count scale 1."""
    model = scene.physics_model()
    return int(pour(scene, model, build_params(scene, model)).n)


if __name__ == '__main__':
    main()
