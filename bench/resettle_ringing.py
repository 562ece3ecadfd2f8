"""The bed's motion over a long re-settle with the tool standing: is its ringing a transient?

The library's pass of a scene (its seed's cached bed, the tool placed, the run's physics) is
re-settled for ``--seconds`` instead of ``tool.settle_s``; every 10 ms the kinetic energy of the
bed, its grains' speeds in units of g dt (the speed gravity adds in one step) and their force
imbalance in units of their weight are printed. Issue 30: the library's 0.06 s re-settle leaves
a ringing bed; this says whether a longer one would end it. Last line: one JSON object.

    NUMBA_NUM_THREADS=1 nice -n 10 .venv/bin/python bench/resettle_ringing.py \\
        --scene reduced_1ms --seconds 0.4 --cache ~/.cache/dempath/packings
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np

from dempath_diagnose.library.simulator import load_scene, pass_scene
from dempath_sim.engine import ToolPose
from dempath_sim.runs.bed import fill_bed
from dempath_sim.runs.native import _prepare_drive, _with_run_masses
from dempath_sim.runs.physics import build_params

GRAVITY = 9.81  # m/s^2


def main() -> None:
    """Re-settle, print a row every 10 ms and the JSON line."""
    p = argparse.ArgumentParser()
    p.add_argument('--scene', default='reduced_1ms')
    p.add_argument('--seed', type=int, default=1001)
    p.add_argument('--seconds', type=float, default=0.4)
    p.add_argument('--cache', type=Path, default=None, help='packing cache')
    args = p.parse_args()
    scene = pass_scene(load_scene(args.scene), args.seed, {})
    model, bed = scene.physics_model(), scene.bed_model()
    params = build_params(scene, model)
    state, report = fill_bed(scene, bed, build_params(scene, bed), args.cache)
    drive, state = _prepare_drive(scene, params, model, _with_run_masses(state, params), report)
    engine = drive.engine
    engine.tool_pose = ToolPose(np.asarray(drive.path.pose_at(0.0)[0]), np.zeros(3))
    dt = float(engine.dt or 0.0)
    g_dt = GRAVITY * dt
    chunk = max(1, round(0.01 / dt))
    rows = []
    while state.time < args.seconds - 1e-9:
        state = engine.run(state, chunk)
        speed = np.sqrt((state.velocities**2).sum(axis=1)) / g_dt
        force, _ = engine.forces
        weight = state.masses * GRAVITY
        net = force.copy()
        net[:, 1] -= weight
        imbalance = np.sqrt((net**2).sum(axis=1)) / weight
        energy = 0.5 * float(np.sum(state.masses * (state.velocities**2).sum(axis=1)))
        rows.append({'t_s': round(state.time, 4), 'kinetic_mj': round(energy * 1e3, 3),
                     'speed_median_gdt': round(float(np.median(speed)), 3),
                     'speed_p99_gdt': round(float(np.percentile(speed, 99)), 2),
                     'speed_max_gdt': round(float(speed.max()), 1),
                     'imbalance_median_weights': round(float(np.median(imbalance)), 3)})
        print(json.dumps(rows[-1]), flush=True)
    print(json.dumps({'scene': scene.name, 'seed': args.seed, 'particles': int(state.n),
                      'dt_s': dt, 'g_dt_m_s': g_dt, 'rows': rows,
                      'load': [round(x, 2) for x in os.getloadavg()]}))


if __name__ == '__main__':
    main()
