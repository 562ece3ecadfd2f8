"""Playback throughput of 1920x1080 camera frames: player -> subscriber and player -> recorder.

Two cameras' frames (raw ``sensor_msgs/Image`` bgr8, 6.2 MB each, and JPEG ``CompressedImage``)
are written to a bag in a temporary folder, then played in one process (launch-free harness):

* ``*_fps``: as fast as possible (rate 0) into a typed subscriber, frames per second between
  the first and the last frame received;
* ``*_record_fps``: as fast as possible into the recorder (raw subscriptions -> MCAP on disk),
  from the recorded bag's receive times;
* ``live_*``: at the original timing, two cameras at 50 FPS (100 frames/s), into the recorder.

``dropped`` adds every frame that was published but not received or not written in all runs.
The target is >= 100 frames/s with 0 dropped. The last line is one JSON object.

Usage: ``.venv/bin/python bench/bag_throughput.py [--frames N] [--tmp DIR]`` (N frames per
camera, default 100; the bags, about 2.5 GB at most, go to DIR).
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from sensor_msgs.msg import CompressedImage, Image

from dempath.bagio import open_bag, write_bag
from dempath.nodes.harness import RosHarness
from dempath.nodes.pipeline import replay_and_record
from dempath.nodes.player import PlayerNode
from dempath.testbags import images
from dempath.typestore import make_typestore

WIDTH, HEIGHT, CAMERAS = 1920, 1080, ('cam_side', 'cam_front')


def make_bag(path: Path, frames: int, jpeg: bool) -> tuple[Path, list[str]]:
    """Two cameras' frames at 50 FPS, interleaved; return the bag and its topics."""
    store = make_typestore()
    msgs = [m for i, cam in enumerate(CAMERAS)
            for m in images(store, frames, WIDTH, HEIGHT, camera=cam, jpeg=jpeg, seed=i)]
    write_bag(path, sorted(msgs, key=lambda m: m[2]), typestore=store)
    return path, sorted({m[0] for m in msgs})


def to_subscriber(bag: Path, topics: list[str], jpeg: bool) -> tuple[float, int]:
    """Frames/s into a typed subscriber at rate 0, and frames not received."""
    msg_type = CompressedImage if jpeg else Image
    with RosHarness() as harness:
        stamps: list[float] = []
        for topic in topics:
            harness.probe.create_subscription(
                msg_type, topic, lambda _: stamps.append(time.monotonic()), 100)
        player = harness.start(PlayerNode, bag=str(bag), rate=0.0, wait_for_subscribers=1,
                               queue_depth=100)
        harness.spin_until(player.finished.is_set, timeout_s=300, step_s=0.01)
        total = player.stats.total if player.stats else 0
        harness.spin_until(lambda: len(stamps) >= total, timeout_s=10, step_s=0.01)
    fps = (len(stamps) - 1) / (stamps[-1] - stamps[0]) if len(stamps) > 1 else 0.0
    return fps, total - len(stamps)


def to_recorder(bag: Path, topics: list[str], out: Path, rate: float) -> tuple[float, int]:
    """Frames/s written by the recorder (from the recorded receive times), and frames lost."""
    result = replay_and_record(bag, out, topics, rate=rate, timeout_s=300, quiet=True)
    published = result.played.total if result.played else 0
    with open_bag(out) as recorded:
        times = [m.log_time_ns for m in recorded.messages()]
    shutil.rmtree(out)  # keep at most one recorded copy of the frames around
    fps = (len(times) - 1) / ((times[-1] - times[0]) * 1e-9) if len(times) > 1 else 0.0
    dropped = sum(s.dropped for s in result.recorded.values())
    if result.played and rate > 0:
        print(f'{bag.name} at rate {rate}: {result.played.behind} frames behind schedule, '
              f'max lag {result.played.max_lag_s:.3f} s', flush=True)
    return fps, max(dropped, published - len(times))


def main() -> None:
    """Run every case and print the figures; the last line is the JSON summary."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--frames', type=int, default=100, help='frames per camera')
    parser.add_argument('--tmp', default=None,
                        help='folder for the bags (default: system temp; /dev/shm leaves the '
                        'disk out of the figures)')
    args = parser.parse_args()
    figures: dict[str, Any] = {'frames': 2 * args.frames, 'width': WIDTH, 'height': HEIGHT}
    dropped = 0
    figures['storage'] = args.tmp or tempfile.gettempdir()
    with tempfile.TemporaryDirectory(prefix='dempath-bench-', dir=args.tmp) as tmp:
        for kind in ('raw', 'jpeg'):
            bag, topics = make_bag(Path(tmp) / kind, args.frames, jpeg=kind == 'jpeg')
            fps, lost = to_subscriber(bag, topics, jpeg=kind == 'jpeg')
            figures[f'{kind}_fps'], dropped = round(fps, 1), dropped + lost
            fps, lost = to_recorder(bag, topics, Path(tmp) / f'{kind}_rec', rate=0.0)
            figures[f'{kind}_record_fps'], dropped = round(fps, 1), dropped + lost
            fps, lost = to_recorder(bag, topics, Path(tmp) / f'{kind}_live', rate=1.0)
            figures[f'live_{kind}_record_fps'] = round(fps, 1)
            figures[f'live_{kind}_dropped'], dropped = lost, dropped + lost
            print(f'{kind}: {figures}', flush=True)
    figures['dropped'] = dropped
    print(json.dumps(figures))


if __name__ == '__main__':
    main()
