"""Raw MCAP reading: dempath's indexed reader (``dempath.mcapread``) against the ``mcap`` package.

Why dempath keeps its own reader (docs/ros.md, "The MCAP reader"): the player and the offline
tools read a few topics of a bag, often from an offset. ``mcapread`` seeks to each wanted message
through the chunks' message indexes; ``mcap``'s ``iter_messages`` reads every chunk whole and
filters. Both read the shipped rendered recording (``bags/field_render_reduced_1ms``,
uncompressed chunks, JPEG images and camera infos of two cameras) from the page cache:

* ``all``: every message, raw bytes (no CDR decoding);
* ``one_topic``: the side camera's camera_info only (a small topic among the images);
* ``from_half``: every message from the middle of the recording on.

Median of ``--repeat`` runs each; messages counted to check that both read the same. The last
line is one JSON object.

Usage: ``.venv/bin/python bench/mcap_reader.py [--repeat N]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

from mcap.reader import make_reader

from dempath import mcapread

BAG = Path(__file__).resolve().parents[1] / 'bags' / 'field_render_reduced_1ms'


def ours(path: Path, topics: set[str], start: int | None) -> tuple[int, int]:
    """(messages, bytes) through dempath.mcapread."""
    n = size = 0
    for _, _, data in mcapread.iter_raw(path, topics, start):
        n, size = n + 1, size + len(data)
    return n, size


def theirs(path: Path, topics: set[str], start: int | None) -> tuple[int, int]:
    """(messages, bytes) through mcap's reader (its index, chunk by chunk)."""
    n = size = 0
    with path.open('rb') as f:
        for _, _, message in make_reader(f).iter_messages(topics=sorted(topics),
                                                          starting_at=start):
            n, size = n + 1, size + len(message.data)
    return n, size


def timed(fn: Callable[[], tuple[int, int]], repeat: int) -> tuple[float, tuple[int, int]]:
    """Median wall time [s] of ``repeat`` calls and the last call's counts."""
    times, out = [], (0, 0)
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main() -> None:
    """Run the three cases both ways; print a table and one JSON line."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--repeat', type=int, default=5)
    args = parser.parse_args()
    (path,) = sorted(BAG.glob('*.mcap'))
    with path.open('rb') as f:
        index = mcapread.read_index(f)
        f.seek(0)
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    every = set(index.topics.values())
    half = (summary.statistics.message_start_time + summary.statistics.message_end_time) // 2
    cases = {'all': (every, None), 'one_topic': ({'/cam_side/camera_info'}, None),
             'from_half': (every, half)}
    figures: dict[str, object] = {'bag_mb': round(path.stat().st_size / 1e6, 1)}
    for name, (topics, start) in cases.items():
        t_ours, n_ours = timed(lambda t=topics, s=start: ours(path, t, s), args.repeat)
        t_theirs, n_theirs = timed(lambda t=topics, s=start: theirs(path, t, s), args.repeat)
        assert n_ours == n_theirs, (name, n_ours, n_theirs)
        figures[name] = {'messages': n_ours[0], 'mcapread_ms': round(1e3 * t_ours, 2),
                         'mcap_ms': round(1e3 * t_theirs, 2),
                         'speedup': round(t_theirs / t_ours, 2)}
        print(f'{name:<10} {n_ours[0]:>6} msgs  mcapread {1e3 * t_ours:8.2f} ms   '
              f'mcap {1e3 * t_theirs:8.2f} ms')
    figures['load_average'] = round(os.getloadavg()[0], 2)
    figures['cpus'] = os.cpu_count()
    print(json.dumps(figures))


if __name__ == '__main__':
    main()
