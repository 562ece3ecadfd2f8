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
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DASK = str(Path(sys.executable).parent / 'dask')


def _isolated() -> bool:
    probe = subprocess.run(['unshare', '--mount', '--propagation', 'private', 'sh', '-c',
                            'mount -t tmpfs tmpfs /tmp'], capture_output=True, check=False)
    return shutil.which('unshare') is not None and probe.returncode == 0


def _worker(address: str, name: str, home: Path, isolated: bool, log: Path) -> subprocess.Popen:
    run = (f'mkdir -p {home}/cache && cd {home} && HOME={home} TMPDIR={home} '
           f'DEMPATH_CACHE_DIR={home}/cache NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 '
           f'exec {DASK} worker {address} --nthreads 1 --no-dashboard --name {name}')
    cmd = (['unshare', '--mount', '--propagation', 'private', 'sh', '-c',
            f'mount -t tmpfs tmpfs /tmp && {run}'] if isolated else ['sh', '-c', run])
    return subprocess.Popen(cmd, stdout=log.open('wb'), stderr=subprocess.STDOUT,
                            start_new_session=True)


def build_once(args: argparse.Namespace, n_workers: int, work: Path) -> dict[str, float]:
    """A fresh library with ``n_workers`` lone workers; its wall time and runs."""
    from distributed import Client

    from dempath_diagnose.library.simulator import load_scene, pass_travel_s
    from dempath_diagnose.library.store import LibrarySpec, build_library, design
    from dempath_diagnose.library.sweep import DaskSweep

    work.mkdir(parents=True)
    port_file = work / 'scheduler.json'
    procs = [subprocess.Popen([DASK, 'scheduler', '--port', '0', '--no-dashboard',
                               '--scheduler-file', str(port_file)],
                              stdout=(work / 'scheduler.log').open('wb'),
                              stderr=subprocess.STDOUT, start_new_session=True)]
    isolated = _isolated()
    try:
        while not port_file.is_file():
            time.sleep(0.1)
        address = json.loads(port_file.read_text())['address']
        for k in range(n_workers):
            home = Path(f'/tmp/lone-{k}') if isolated else work / f'lone-{k}'
            procs.append(_worker(address, f'lone{k}', home, isolated, work / f'worker{k}.log'))
        with Client(address, timeout=30) as client:
            client.wait_for_workers(n_workers, timeout=120)
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
        for p in reversed(procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    os.killpg(p.pid, signal.SIGKILL)


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
