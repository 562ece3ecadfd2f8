"""Benchmark: is the live node graph deterministic on a bag, and equal to the offline path?

Plays a bag of the bundled render's field frames (both cameras, 31 frames each) through the real
nodes, in one process on one executor: ``dempath_player`` (as fast as the subscribers take it,
``rate 0``, the worst case for arrival order) -> two ``dempath_detector`` nodes with
``lossless`` (each tracks both cameras merged by stamp, the demo's setting when playing a bag)
-> their ``pixel_points``, collected. Repeats ``--runs`` times (default 3) and compares every
run's numbered points with the others and with ``track_bag`` (the offline path) on the same bag.

Prints one JSON line last: ``runs``, ``identical_runs`` (every run the same points as the first),
``equal_to_offline`` (every run equal to ``track_bag``), ``frames_per_run`` (per camera),
``lost_frames`` (frames of the bag with no published points, per run), ``player_detail`` (the
player's FINISHED event of each run: whether every message was acknowledged), ``numbered`` (points
with a number, per run), and the machine's load average.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from dempath import topics
from dempath.bagio import open_bag, write_bag
from dempath.nodes.harness import RosHarness
from dempath.nodes.player import PlayerNode
from dempath_calib.camera import StereoCalibration
from dempath_msgs.msg import PixelPoints, RunEvent
from dempath_recon.nodes.detector import DetectorNode
from dempath_recon.tracking.stereo import track_bag

HERE = Path(__file__).resolve().parent
DEFAULT_BAG = HERE.parent / 'bags' / 'field_render_reduced_1ms'
RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
Points = dict[tuple[str, int], dict[int, tuple[float, float]]]  # (camera, stamp us) -> points


def field_bag(bag: Path, out: Path) -> tuple[Path, StereoCalibration, int]:
    """A bag of ``bag``'s field frames (images only), the true calibration, frames per camera."""
    truth = json.loads(bag.with_name(bag.name + '.truth.json').read_text())
    start = int(truth['calibration_segment']['field_start_ns'])
    wanted = [topics.camera_topic(topics.IMAGE_COMPRESSED, c) for c in topics.CAMERAS]
    with open_bag(bag, wanted) as reader:
        msgs = [(r.topic, r.msgtype, r.log_time_ns, r.data) for r in reader.messages(wanted)
                if r.log_time_ns >= start]
    write_bag(out, msgs)
    rig = StereoCalibration.from_dict(truth['calibration_segment']['rig'])
    return out, rig, len(msgs) // 2


def play_once(bag: Path, calib: Path, frames: int) -> tuple[Points, str]:
    """One run of player -> two lossless detectors; their points and the player's FINISHED."""
    with RosHarness() as ros:
        got = {}
        for cam in topics.CAMERAS:
            params = [Parameter('camera', value=cam), Parameter('lossless', value=True),
                      Parameter('calibration_file', value=str(calib)),
                      Parameter('merge_wait_s', value=5.0)]
            ros.add(DetectorNode(context=ros.context, namespace=cam, parameter_overrides=params))
            got[cam] = ros.collect(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, cam),
                                   RELIABLE)
        events = ros.collect(RunEvent, topics.PLAYER_EVENTS, LATCHED)
        ros.spin_for(0.5)
        player = ros.start(PlayerNode, bag=str(bag), rate=0.0, wait_for_subscribers=2,
                           topics=[topics.camera_topic(topics.IMAGE_COMPRESSED, c)
                                   for c in topics.CAMERAS])
        ros.spin_until(player.finished.is_set, timeout_s=600)
        ros.spin_until(lambda: all(len(got[c]) >= frames for c in topics.CAMERAS),
                       timeout_s=120)
        ros.spin_for(0.5)
        detail = next((e.detail for e in events if e.event == RunEvent.FINISHED), 'no FINISHED')
        out: Points = {}
        for cam in topics.CAMERAS:
            for msg in got[cam]:
                stamp = int(msg.header.stamp.sec) * 10**9 + int(msg.header.stamp.nanosec)
                out[(cam, round(stamp / 1000))] = {
                    int(m): (float(u), float(v))
                    for m, u, v in zip(msg.marker_ids, msg.u, msg.v, strict=True)}
    return out, detail


def same(a: Points, b: Points) -> bool:
    """The same frames, numbers and pixels (to 1e-4 px: the message's float32)."""
    return a.keys() == b.keys() and all(
        a[k].keys() == b[k].keys() and all(np.allclose(a[k][m], b[k][m], atol=1e-4)
                                           for m in a[k]) for k in a)


def main(argv: list[str]) -> int:
    """Run the graph ``--runs`` times and print the JSON line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument('bag', nargs='?', type=Path, default=DEFAULT_BAG)
    p.add_argument('--runs', type=int, default=3)
    args = p.parse_args(argv)
    load = [round(x, 2) for x in os.getloadavg()]
    with tempfile.TemporaryDirectory() as tmp:
        bag, rig, frames = field_bag(args.bag, Path(tmp) / 'field')
        calib = rig.save(Path(tmp) / 'calib.yaml')
        offline_frames, _ = track_bag(bag, {c.name: c for c in rig.cameras})
        offline: Points = {(f.camera, round(f.stamp_s * 1e6)): {
            int(m): (float(q[0]), float(q[1])) for m, q in zip(f.markers, f.uv, strict=True)
            if m >= 0} for f in offline_frames}
        runs: list[tuple[Points, str]] = [play_once(bag, calib, frames)
                                          for _ in range(args.runs)]
    first = runs[0][0]
    figures: dict[str, Any] = {
        'runs': args.runs, 'identical_runs': all(same(r, first) for r, _ in runs),
        'equal_to_offline': all(same(r, offline) for r, _ in runs),
        'frames_per_run': frames,
        'lost_frames': [len(offline.keys() - r.keys()) for r, _ in runs],
        'numbered': [sum(len(v) for v in r.values()) for r, _ in runs],
        'numbered_offline': sum(len(v) for v in offline.values()),
        'player_detail': [d for _, d in runs],
        'load_average': load, 'load_average_end': [round(x, 2) for x in os.getloadavg()],
        'cpus': os.cpu_count()}
    print(json.dumps(figures))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
