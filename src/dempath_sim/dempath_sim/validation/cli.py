"""``dempath validate``: the physics validation report (Markdown + PNG plots + JSON).

Runs the two-sphere impact, incline, energy and angle-of-repose cases on dempath and, unless
``--no-liggghts`` or LIGGGHTS is missing, on LIGGGHTS; ``--cross-engine SCENE`` adds the
cross-engine comparison of that scene over ``--seeds`` packing seeds per engine. ``--repose``
picks the angle-of-repose set-up (``quick``, ``standard``, ``large``), ``--repose-seeds`` how
many packing seeds it runs, and ``--cases`` a subset of the cases.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from dempath.errors import DempathError
from dempath_sim.validation import CASES


def _repose_overrides(items: list[str]) -> dict[str, float]:
    """``FIELD=VALUE`` strings -> overrides checked against the repose set-up's fields."""
    from dempath_sim.validation.repose import preset_case

    out = {}
    for item in items:
        key, sep, value = item.partition('=')
        try:
            out[key.strip()] = float(value)
        except ValueError:
            sep = ''
        if not sep:
            msg = f'{item!r}: expected FIELD=NUMBER'
            raise ValueError(msg)
    preset_case('standard', 0, out)  # raises on an unknown field or a bad value
    return out


def validate_main(argv: list[str]) -> int:
    """``dempath validate``: the physics validation report, dempath beside LIGGGHTS."""
    parser = argparse.ArgumentParser(prog='dempath validate', description=__doc__)
    parser.add_argument('--out', type=Path, default=Path('validation_report'))
    parser.add_argument('--no-liggghts', action='store_true', help='dempath only')
    parser.add_argument('--quick', action='store_true', help='smaller repose pile')
    parser.add_argument('--repose', choices=('quick', 'standard', 'large'), default=None,
                        help='repose set-up (default standard; large: 100 mm tube, 10,400 '
                        'spheres, ~5x the run time)')
    parser.add_argument('--repose-seeds', type=int, default=1,
                        help='repose packing seeds 0..N-1')
    parser.add_argument('--repose-set', action='append', default=[], metavar='FIELD=VALUE',
                        help='override a repose set-up field, e.g. lift_speed=0.02 [SI]')
    parser.add_argument('--cases', default=','.join(CASES),
                        help=f'comma-separated subset of {",".join(CASES)}')
    parser.add_argument('--cross-engine', metavar='SCENE', default=None,
                        help='also compare dempath and LIGGGHTS on this scene')
    parser.add_argument('--seeds', type=int, default=3, help='packing seeds per engine')
    parser.add_argument('--np', dest='nprocs', type=int, default=1, help='LIGGGHTS processes')
    parser.add_argument('--shared-packing', action='store_true',
                        help="LIGGGHTS starts from dempath's packing of each seed")
    args = parser.parse_args(argv)
    if args.seeds < 2:
        print(f'error: --seeds: need at least 2 for a spread, got {args.seeds}', file=sys.stderr)
        return 1
    if args.repose_seeds < 1:
        print(f'error: --repose-seeds: need at least 1, got {args.repose_seeds}',
              file=sys.stderr)
        return 1
    try:
        overrides = _repose_overrides(args.repose_set)
    except ValueError as err:
        print(f'error: --repose-set: {err}', file=sys.stderr)
        return 1
    cases = tuple(c.strip() for c in args.cases.split(',') if c.strip())
    if not cases or set(cases) - set(CASES):
        print(f'error: --cases: {args.cases!r}: expected a subset of {",".join(CASES)}',
              file=sys.stderr)
        return 1
    from dempath_sim.liggghts.errors import LiggghtsNotFoundError
    from dempath_sim.liggghts.install import ensure_liggghts
    from dempath_sim.scene import load_scene
    from dempath_sim.validation.cross_engine import run_cross_engine
    from dempath_sim.validation.validation_report import write_report

    use_liggghts = not args.no_liggghts
    try:
        if use_liggghts:
            try:
                ensure_liggghts(install=True)
            except LiggghtsNotFoundError as err:
                logging.warning('LIGGGHTS skipped: %s', err)
                use_liggghts = False
        cross = None
        if args.cross_engine and use_liggghts:
            scene = load_scene(args.cross_engine)
            report = run_cross_engine(scene, list(range(1, args.seeds + 1)),
                                      args.out / 'work' / 'cross', args.nprocs,
                                      shared_packing=args.shared_packing)
            cross = (report, scene.name)
        path = write_report(args.out, use_liggghts, args.quick, cross, args.repose,
                            args.repose_seeds, cases, overrides)
    except DempathError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    print(f'report: {path}')
    return 0
