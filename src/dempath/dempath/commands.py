"""``dempath`` subcommands for bags: ``bag-info``, ``bag-recover``, ``play`` and ``record``.

Each is ``x_main(argv) -> int``: bad input gives one ``error: <input>: <problem>`` line and 1
(the dispatcher prints :class:`~dempath.errors.DempathError` the same way).
"""

from __future__ import annotations

import argparse
import sys
from datetime import UTC, datetime
from pathlib import Path

from dempath.bagio import open_bag
from dempath.errors import DempathError
from dempath.mcapbag import check_output_dir, recover_bag


def _fail(err: DempathError | str) -> int:
    print(f'error: {err}', file=sys.stderr)
    return 1


def bag_info_main(argv: list[str]) -> int:
    """``dempath bag-info BAG [--topics T ...]``: topics, types, counts and time span."""
    parser = argparse.ArgumentParser(prog='dempath bag-info', description=bag_info_main.__doc__)
    parser.add_argument('bag', type=Path, help='bag directory or .mcap/.db3 file')
    parser.add_argument('--topics', nargs='*', default=[], help='topics that must be present')
    args = parser.parse_args(argv)
    try:
        with open_bag(args.bag, args.topics) as bag:
            start = datetime.fromtimestamp(bag.start_ns * 1e-9, UTC).isoformat()
            print(f'bag:      {args.bag}')
            print(f'start:    {start}')
            print(f'duration: {(bag.end_ns - bag.start_ns) * 1e-9:.3f} s')
            print(f'messages: {bag.message_count}')
            for info in bag.select(args.topics):
                print(f'  {info.name:<34} {info.msgtype:<36} {info.msgcount:>8}')
    except DempathError as err:
        return _fail(err)
    return 0


def bag_recover_main(argv: list[str]) -> int:
    """``dempath bag-recover BAG``: make an interrupted MCAP recording readable again.

    Keeps every message up to the last complete chunk, rewrites a clean .mcap (the damaged one
    stays as ``*.mcap.broken``) and writes ``metadata.yaml``.
    """
    parser = argparse.ArgumentParser(prog='dempath bag-recover',
                                     description=bag_recover_main.__doc__)
    parser.add_argument('bag', type=Path, help='bag directory holding .mcap files')
    args = parser.parse_args(argv)
    try:
        report = recover_bag(args.bag)
    except DempathError as err:
        return _fail(err)
    for name, count in report.kept.items():
        how = (f'rebuilt, stopped at: {report.stopped_at[name]}' if name in report.rebuilt
               else 'intact')
        print(f'{args.bag / name}: {count} messages ({how})')
    print(f'{args.bag / "metadata.yaml"}: written')
    return 0


def play_main(argv: list[str]) -> int:
    """``dempath play BAG``: replay a bag with its original timing, header stamps and /clock."""
    parser = argparse.ArgumentParser(prog='dempath play', description=play_main.__doc__)
    parser.add_argument('bag', type=Path, help='bag directory or .mcap/.db3 file')
    parser.add_argument('--rate', type=float, default=1.0, help='speed factor (0: no waiting)')
    parser.add_argument('--start-offset', type=float, default=0.0, help='skip seconds [s]')
    parser.add_argument('--loop', action='store_true', help='start again at the end')
    parser.add_argument('--topics', nargs='*', default=[], help='topics to play (default all)')
    parser.add_argument('--wait-for-subscribers', type=int, default=0,
                        help='wait until each topic has this many subscribers')
    parser.add_argument('--skip-unknown', action='store_true',
                        help='play the rest when a topic type cannot be imported')
    args = parser.parse_args(argv)
    from dempath.nodes.msgtypes import import_message_class
    from dempath.nodes.pipeline import run_player
    try:
        with open_bag(args.bag, args.topics) as bag:
            for info in bag.select(args.topics):
                try:
                    import_message_class(info.msgtype)
                except DempathError as err:
                    if not args.skip_unknown:
                        return _fail(f'{args.bag}: topic {info.name}: {err}')
    except DempathError as err:
        return _fail(err)
    stats = run_player({'bag': str(args.bag), 'rate': args.rate, 'loop': args.loop,
                        'start_offset_s': args.start_offset, 'topics': args.topics or [''],
                        'wait_for_subscribers': args.wait_for_subscribers})
    if stats is None:
        return _fail(f'{args.bag}: playback did not start')
    if stats.error:
        return _fail(stats.error)
    print(f'{args.bag}: published {stats.total} messages')
    return 0


def record_main(argv: list[str]) -> int:
    """``dempath record -o BAG [TOPIC ...]``: record topics (default every dempath topic)."""
    parser = argparse.ArgumentParser(prog='dempath record', description=record_main.__doc__)
    parser.add_argument('topics', nargs='*', help='topics (default: every dempath topic)')
    parser.add_argument('-o', '--output', type=Path, help='bag directory to create')
    parser.add_argument('--compression', default='none', choices=['none', 'zstd'])
    parser.add_argument('--flush-period', type=float, default=1.0,
                        help='longest time before a message is on disk [s]')
    args = parser.parse_args(argv)
    output = args.output or Path(datetime.now(UTC).strftime('rosbag2_%Y_%m_%d-%H_%M_%S'))
    try:
        check_output_dir(output)
    except DempathError as err:
        return _fail(err)
    from dempath.nodes.pipeline import run_recorder
    summary = run_recorder({'output': str(output), 'topics': args.topics or [''],
                            'compression': args.compression,
                            'flush_period_s': args.flush_period})
    print(summary or f'error: {output}: nothing recorded', file=sys.stderr)
    return 0 if summary else 1
