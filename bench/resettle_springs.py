"""What starts the ringing of a library run's bed: its contact springs (issue 30).

A library run starts from the seed's cached bed, which holds the grains' positions and
velocities but not their contact springs, places the tool and re-settles. This bench re-settles
one such bed (the scene's baseline physics, the tool in place) for ``--settle`` seconds and then
goes on for ``--after`` seconds twice from the same grains: with the same engine (its springs
kept) and with a fresh engine bound to a copy of the grains (no springs, as when a run starts
from the cache). Every ``--frame`` it reports the mean vertical speed of the grains that start
within ``--keep-depth`` of the surface (their mean displacement over the frame / the frame),
and the mean and largest drift speed. If the fresh engine's bed sinks again where the kept one
does not, the missing springs are what sets the bed ringing. The last line is one JSON object.

Usage: ``.venv/bin/python bench/resettle_springs.py [--scene reduced_1ms] [--seed 1001]
[--settle 0.25] [--after 0.06] [--frame 0.005] [--cache DIR]``
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.library.simulator import ensure_bed, load_scene
from dempath_sim.engine import Engine, SimState, ToolPose, TriangleMesh
from dempath_sim.runs.bed import fill_bed
from dempath_sim.runs.native import _prepare_drive, _with_run_masses
from dempath_sim.runs.physics import TOOL, bin_walls, build_params


def by_id(state: SimState) -> NDArray[np.float64]:
    """Positions ordered by particle id (the engine reorders its arrays at list builds)."""
    return np.asarray(state.positions[np.argsort(state.ids)])


def follow(engine: Engine, state: SimState, watch: NDArray[np.bool_], steps: int, frames: int,
           ) -> tuple[SimState, list[dict[str, float]]]:
    """Step ``frames`` frames of ``steps`` steps; the watched grains' speeds per frame [m/s]."""
    frame_s = steps * float(engine.dt or 0.0)
    rows = []
    for _ in range(frames):
        prev = by_id(state)
        state = engine.run(state, steps)
        now = by_id(state)
        move = now[watch] - prev[watch]
        speed = np.linalg.norm(move, axis=1)
        rows.append({'t': round(state.time, 4),
                     'mean_vy': round(float(move[:, 1].mean()) / frame_s, 5),
                     'mean': round(float(speed.mean()) / frame_s, 5),
                     'max': round(float(speed.max()) / frame_s, 5)})
    return state, rows


def main() -> None:
    """Run the two branches and print one JSON line last."""
    p = argparse.ArgumentParser()
    p.add_argument('--scene', default='reduced_1ms')
    p.add_argument('--seed', type=int, default=1001)
    p.add_argument('--settle', type=float, default=0.25)
    p.add_argument('--after', type=float, default=0.06)
    p.add_argument('--frame', type=float, default=0.005)
    p.add_argument('--keep-depth', type=float, default=0.04)
    p.add_argument('--cache', type=Path,
                   default=Path.home() / '.cache/dempath/bench-diagnose/packings')
    args = p.parse_args()
    scene = load_scene(args.scene).with_overrides(seed=args.seed)
    ensure_bed(scene, args.cache)
    load, t0 = os.getloadavg()[0], time.monotonic()
    model = scene.physics_model()
    params = build_params(scene, model)
    bed = scene.bed_model()
    state, report = fill_bed(scene, bed, build_params(scene, bed), args.cache)
    state = _with_run_masses(state, params)
    drive, state = _prepare_drive(scene, params, model, state, report)
    engine = drive.engine
    engine.tool_pose = ToolPose(np.asarray(drive.path.pose_at(0.0)[0]), np.zeros(3))
    watch = by_id(state)[:, 1] >= report.surface_height_m - args.keep_depth
    steps = max(1, round(args.frame / float(engine.dt or 1.0)))
    frame_s = steps * float(engine.dt or 0.0)
    state, settle = follow(engine, state, watch, steps, round(args.settle / frame_s))
    twin_state = copy.deepcopy(state)
    mesh = TriangleMesh.from_stl(scene.tool.mesh, material=TOOL, scale=scene.tool.scale)
    twin = Engine(params, bin_walls(scene), mesh)
    twin.tool_pose = engine.tool_pose
    twin.bind(twin_state)
    frames = round(args.after / frame_s)
    _, kept = follow(engine, state, watch, steps, frames)
    _, dropped = follow(twin, twin_state, watch, steps, frames)
    out: dict[str, Any] = {
        'scene': scene.name, 'seed': args.seed, 'load': [round(load, 2),
                                                         round(os.getloadavg()[0], 2)],
        'wall_s': round(time.monotonic() - t0, 1), 'watched': int(watch.sum()),
        'frame_s': round(frame_s, 6), 'settle': settle, 'kept': kept, 'dropped': dropped}
    print(json.dumps(out))


if __name__ == '__main__':
    main()
