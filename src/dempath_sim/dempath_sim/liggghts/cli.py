"""``dempath liggghts SCENE``: run a scene on LIGGGHTS 3.8 and write the same outputs as dempath.

Writes to ``--out``: the decks, logs and dumps, ``result.npz`` (SimResult), ``markers.csv``
(t,marker,x,y,z), ``model.csv`` (t,id,marker,x,y,z) and ``tool.csv``. ``--install`` apt-installs
LIGGGHTS when it is missing (root only).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from dempath.errors import DempathError


def liggghts_main(argv: list[str]) -> int:
    """``dempath liggghts SCENE``: run a scene on LIGGGHTS 3.8, same outputs as dempath."""
    parser = argparse.ArgumentParser(prog='dempath liggghts', description=__doc__)
    parser.add_argument('scene', help='scene YAML file or builtin:NAME')
    parser.add_argument('--out', type=Path, default=Path('liggghts_run'), help='output dir')
    parser.add_argument('--np', dest='nprocs', type=int, default=1, help='MPI processes')
    parser.add_argument('--seed', type=int, default=None, help='packing seed override')
    parser.add_argument('--friction', choices=('static', 'dynamic'), default='static',
                        help="dempath coefficient used as LIGGGHTS' single friction")
    parser.add_argument('--install', action='store_true', help='apt-get install if missing')
    args = parser.parse_args(argv)
    if args.nprocs < 1:
        print(f'error: --np: must be >= 1, got {args.nprocs}', file=sys.stderr)
        return 1
    from dempath_sim.liggghts.backend import LiggghtsBackend
    from dempath_sim.liggghts.install import ensure_liggghts
    from dempath_sim.scene import load_scene

    try:
        scene = load_scene(args.scene)
        if args.seed is not None:
            scene = scene.with_overrides(seed=args.seed)
        ensure_liggghts(install=args.install)
        result = LiggghtsBackend(args.out, args.nprocs, args.friction).run(scene)
        result.save_npz(args.out / 'result.npz')
        result.write_marker_csv(args.out / 'markers.csv')
        result.write_model_csv(args.out / 'model.csv')
        result.write_tool_csv(args.out / 'tool.csv')
    except DempathError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    fill = result.meta['fill']
    print(f'{scene.name}: {int(fill["n_particles"])} particles, surface '
          f'{fill["surface_height_m"]:.4f} m, {len(result.times)} frames, mean draft '
          f'{float(result.draft_force()[1:].mean()):.2f} N -> {args.out}')
    return 0
