"""Library build through a `dask scheduler` with 1 and then 2 workers that share no disk with us.

Each worker is a `dask worker` process (one thread, one numba thread) with its own HOME, TMPDIR,
packing cache and folder (and, where the machine allows it, its own mount namespace with an
empty /tmp, as a worker on another host). For each worker count, a fresh library of the scene
is built from scratch into a fresh folder (the pours included) and timed; the speed-up is the
ratio. The last line is one JSON object.

Usage: ``nice -n 10 .venv/bin/python bench/scale_out.py [--scene tiny] [--seeds 1001,1002,1003]
[--candidates tool_speed,cohesion] [--workers 1,2]``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from dempath_diagnose.library.dask_processes import (
    lone_worker_command,
    namespaces_allowed,
    start_group,
    start_scheduler,
    stop_groups,
    wait_for_workers,
)


def build_once(args: argparse.Namespace, n_workers: int, work: Path) -> dict[str, float]:
    """A fresh library with ``n_workers`` lone workers; its wall time and runs."""
    from dempath_diagnose.library.simulator import load_scene, pass_travel_s
    from dempath_diagnose.library.store import LibrarySpec, build_library, design
    from dempath_diagnose.library.sweep import DaskSweep

    work.mkdir(parents=True)
    proc, address = start_scheduler(work)
    procs = [proc]
    isolated = namespaces_allowed(Path('/tmp'))
    try:
        for k in range(n_workers):
            home = Path(f'/tmp/lone-{k}') if isolated else work / f'lone-{k}'
            procs.append(start_group(lone_worker_command(address, home, f'lone{k}',
                                                         Path('/tmp') if isolated else None),
                                     work / f'worker{k}.log'))
        wait_for_workers(address, n_workers)
        scene = load_scene(args.scene)
        spec = LibrarySpec(seeds=tuple(int(s) for s in args.seeds.split(',')),
                           candidates=tuple(args.candidates.split(',')),
                           duration_s=round(pass_travel_s(scene, {}) + 0.2, 6), n_strengths=1)
        t0 = time.monotonic()
        with DaskSweep(address) as sweep:
            build_library(scene, spec, work / 'library', sweep.run, work / 'packings',
                          worker_cache=None)
        wall = time.monotonic() - t0
        return {'workers': n_workers, 'runs': len(design(scene, spec)[1]),
                'wall_s': round(wall, 1), 'isolated': isolated}
    finally:
        stop_groups(procs)


def main() -> None:
    """Build with each worker count and print the figures (one JSON line last)."""
    p = argparse.ArgumentParser()
    p.add_argument('--scene', default='tiny')
    p.add_argument('--seeds', default='1001,1002,1003')
    p.add_argument('--candidates', default='tool_speed,cohesion')
    p.add_argument('--workers', default='1,2')
    args = p.parse_args()
    load = os.getloadavg()[0]
    rows = []
    with tempfile.TemporaryDirectory(prefix='scale-out-') as tmp:
        for n in (int(v) for v in args.workers.split(',')):
            rows.append(build_once(args, n, Path(tmp) / f'w{n}'))
            print(json.dumps(rows[-1]), flush=True)
    first = rows[0]['wall_s']
    print(json.dumps({'scene': args.scene, 'builds': rows,
                      'speedup': {str(r['workers']): round(first / r['wall_s'], 2)
                                  for r in rows},
                      'load_1min_before': round(load, 1),
                      'load_1min_after': round(os.getloadavg()[0], 1),
                      'cores': os.cpu_count()}))


if __name__ == '__main__':
    main()
