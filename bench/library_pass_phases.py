"""Where one signature-library pass spends its time, and whether its bed comes to rest.

Runs one library pass of a scene (the baseline on a library seed, as ``run_pass`` runs it:
the seed's bed poured with the scene file's physics, the tool placed, the re-settle against the
tool with the run's physics, the pass and the follow after the tool stops, whole-bed frames
every ``--frame-s``) and times each phase in wall and CPU seconds of this process (all numba
threads). After the tool stops it reports, per frame, the largest and the 99th-percentile
displacement of the near-surface particles since the frame before, and the frame at which the
stop-at-rest rule (``dempath_sim.runs.rest``) with ``--rest-tolerance-m`` would end the run.
The pour is cached (``--cache``): a rerun times the pass only. Last line: one JSON object.

    NUMBA_NUM_THREADS=1 nice -n 10 .venv/bin/python bench/library_pass_phases.py \\
        --scene reduced_1ms --seed 1001 --cache ~/.cache/dempath/phases
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from dempath_diagnose.library.simulator import _sweep_scene, load_scene, pass_travel_s
from dempath_sim.runs import RunOptions
from dempath_sim.runs.bed import fill_bed
from dempath_sim.runs.native import _prepare_drive, _with_run_masses, drive_tool, resettle
from dempath_sim.runs.physics import build_params


def clocks() -> tuple[float, float]:
    """(wall, CPU of this process and its threads) [s]."""
    return time.monotonic(), time.process_time()


def main() -> None:
    """Run the pass and print one JSON line last."""
    p = argparse.ArgumentParser()
    p.add_argument('--scene', default='reduced_1ms')
    p.add_argument('--seed', type=int, default=1001)
    p.add_argument('--cache', type=Path, default=Path.home() / '.cache/dempath/phases')
    p.add_argument('--frame-s', type=float, default=0.02)
    p.add_argument('--follow-s', type=float, default=0.2)
    p.add_argument('--keep-depth-m', type=float, default=0.04)
    p.add_argument('--rest-tolerance-m', type=float, default=1e-4)
    args = p.parse_args()
    scene = load_scene(args.scene)
    base = _sweep_scene(scene.with_overrides(seed=args.seed))
    base = replace(base, output=replace(base.output, snapshot_interval_s=args.frame_s,
                                        candidates=False))
    model, bed = base.physics_model(), base.bed_model()
    params = build_params(base, model)
    w0, c0 = clocks()
    state, report = fill_bed(base, bed, build_params(base, bed), args.cache)
    state = _with_run_masses(state, params)
    w1, c1 = clocks()
    drive, state = _prepare_drive(base, params, model, state, report)
    state = resettle(drive, state, base.tool.settle_s)
    w2, c2 = clocks()
    travel = pass_travel_s(scene, {})
    state = drive_tool(drive, state, RunOptions(follow_s=args.follow_s))
    w3, c3 = clocks()
    result = drive.recorder.result({})
    snaps = np.asarray(result.snapshot_positions, np.float64)
    times = np.asarray(result.snapshot_times)
    keep = snaps[0, :, 1] >= report.surface_height_m - args.keep_depth_m
    step = np.linalg.norm(np.diff(snaps[:, keep], axis=0), axis=2)
    after = np.flatnonzero(times[1:] > drive.end_time_s + 1e-9)
    rows = [{'t': round(float(times[k + 1]), 3),
             'max_mm': round(float(np.nanmax(step[k])) * 1e3, 3),
             'p99_mm': round(float(np.nanpercentile(step[k], 99)) * 1e3, 3),
             'median_mm': round(float(np.nanmedian(step[k])) * 1e3, 4)} for k in after]
    left = [times[-1] - times[k + 1] for k in after]
    fires = [r['t'] for r, rest in zip(rows, left, strict=True)
             if r['max_mm'] * 1e-3 * max(rest / args.frame_s, 1.0) <= args.rest_tolerance_m]
    out = {'scene': scene.name, 'seed': args.seed, 'particles': int(state.n),
           'kept': int(keep.sum()), 'dt_s': drive.engine.dt, 'travel_s': travel,
           'end_s': round(float(times[-1]), 4),
           'pour_wall_s': round(w1 - w0, 1), 'pour_cpu_s': round(c1 - c0, 1),
           'from_cache': bool(report.from_cache),
           'resettle_s': base.tool.settle_s,
           'resettle_wall_s': round(w2 - w1, 1), 'resettle_cpu_s': round(c2 - c1, 1),
           'drive_wall_s': round(w3 - w2, 1), 'drive_cpu_s': round(c3 - c2, 1),
           'rest_rule_fires_at_s': fires[0] if fires else None,
           'after_stop': rows, 'threads': os.environ.get('NUMBA_NUM_THREADS', ''),
           'load': os.getloadavg()}
    print(json.dumps(out))


if __name__ == '__main__':
    main()
