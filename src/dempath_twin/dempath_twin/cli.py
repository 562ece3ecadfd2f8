"""``dempath rig`` (the twin rig's cameras, or its calibration bag with the truth) and
``dempath twin field`` (the demo's field twin bag)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import yaml  # type: ignore[import-untyped]

from dempath.errors import DempathError
from dempath_twin.board.bag import truth_path, write_calibration_bag
from dempath_twin.rig import paper_rig


def rig_main(argv: list[str]) -> int:
    """``dempath rig [OUT_BAG]``: print the twin rig's cameras, or write its calibration bag."""
    p = argparse.ArgumentParser(prog='dempath rig', description='The twin rig: print its true '
                                'cameras (YAML), or render its calibration recording into a '
                                'rosbag2 MCAP bag with the truth JSON beside it.')
    p.add_argument('bag', nargs='?', help='bag folder to create')
    p.add_argument('--views', type=int, default=40, help='board poses')
    p.add_argument('--seed', type=int, default=0)
    p.add_argument('--raw', action='store_true', help='mono8 Image instead of JPEG')
    p.add_argument('--front-delay', type=float, default=0.0, help='front clock delay [s]')
    p.add_argument('--quality', type=int, default=92, help='JPEG quality (0-100)')
    args = p.parse_args(argv)
    if args.bag is None:
        print(yaml.safe_dump(paper_rig().to_dict(), sort_keys=False))
        return 0
    if Path(args.bag).exists():
        print(f'error: {args.bag}: already exists', file=sys.stderr)
        return 1
    if args.views < 1:
        print(f'error: --views: must be >= 1, got {args.views}', file=sys.stderr)
        return 1
    bag = write_calibration_bag(args.bag, args.views, args.seed, not args.raw,
                                front_delay_s=args.front_delay, quality=args.quality)
    print(json.dumps({'bag': str(bag), 'truth': str(truth_path(bag))}))
    return 0


def twin_main(argv: list[str]) -> int:
    """``dempath twin field|render ...``: make a field twin (clicked points or rendered images).

    ``dempath twin field OUT ...`` (clicked field twin) or ``dempath twin render SOURCE --out
    BAG ...`` (rendered field recording, :func:`dempath_twin.render.bag.render_main`).
    """
    from dempath_twin.field.demo_bag import make_field_twin

    if argv[:1] == ['render']:
        from dempath_twin.render.bag import render_main

        return render_main(argv[1:])

    p = argparse.ArgumentParser(prog='dempath twin', description='Synthetic recordings.')
    sub = p.add_subparsers(dest='what', required=True)
    sub.add_parser('render', help='rendered field recording of a run (see: twin render -h)')
    f = sub.add_parser('field', help='field twin: a hidden DEM run seen by the twin rig')
    f.add_argument('out', type=Path, help='bag folder to create (replaced if it exists)')
    f.add_argument('--scene', default='tiny', help='shipped scene name or scene file')
    f.add_argument('--sim-dir', type=Path, help='output folder of the hidden dempath run')
    args = p.parse_args(argv)
    try:
        truth = make_field_twin(args.out, args.scene, args.sim_dir)
    except (DempathError, OSError) as err:
        print(f'error: {args.scene}: {err}', file=sys.stderr)
        return 1
    size = sum(f.stat().st_size for f in args.out.iterdir())
    print(f'{args.out}: {truth["frames"]} frames, {size / 1e6:.2f} MB, '
          f'{truth["outside_image_points"]} clicks outside the images')
    return 0
