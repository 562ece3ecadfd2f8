"""Live reconstruction at 50 FPS per camera: does the reconstructor keep up on this machine?

Pixel points of 15 markers (the twin rig's projections) stream in real time at ``--fps`` per
camera for ``--seconds`` into ``dempath_reconstructor`` (launch-free harness, one process), as
detectors would publish them. Figures from the node's own counts on ``/diagnostics``:
``kept_fraction`` (instants reconstructed / frame pairs sent), ``dropped_behind`` (frames the
worker dropped because it was behind), ``unpaired``, ``most_waiting`` (largest work queue), and
``pair_ms`` (core cost of one pair, measured alone). The last line is one JSON object.

Usage: ``.venv/bin/python bench/live_rig.py [--seconds 10] [--fps 50] [--method dlt]``
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from std_msgs.msg import Header

from dempath import topics
from dempath.nodes.harness import RosHarness
from dempath_msgs.msg import PixelPoints
from dempath_recon.nodes.convert import s_to_stamp
from dempath_recon.nodes.reconstructor import ReconstructorNode
from dempath_recon.pairing import PixelFrame
from dempath_recon.stream import MarkerStream, StreamConfig
from dempath_twin.rig import paper_rig, sample_working_volume


def points_msg(camera: str, stamp_s: float, uv: np.ndarray) -> PixelPoints:
    """15 detected markers of one camera frame."""
    return PixelPoints(header=Header(stamp=s_to_stamp(stamp_s), frame_id=camera),
                       marker_ids=list(range(1, 16)), u=uv[:, 0].tolist(), v=uv[:, 1].tolist(),
                       confidence=[1.0] * 15, source=[PixelPoints.SOURCE_DETECTED] * 15)


def pair_ms(calib: str, method: str, uv: list[np.ndarray], n: int = 50) -> float:
    """Core cost of one frame pair [ms] (no ROS)."""
    stream = MarkerStream.from_config(StreamConfig.from_params(
        {'method': method, 'calibration_file': calib}))
    t0 = time.perf_counter()
    for k in range(n):
        stream.update(PixelFrame(0, k / 50, np.arange(1, 16), uv[0]))
        stream.update(PixelFrame(1, k / 50 + 0.003, np.arange(1, 16), uv[1]))
    return 1e3 * (time.perf_counter() - t0) / n


def main() -> None:
    """Stream, settle, print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--seconds', type=float, default=10.0)
    parser.add_argument('--fps', type=float, default=50.0)
    parser.add_argument('--method', default='dlt')
    args = parser.parse_args()
    rig = paper_rig()
    xyz = sample_working_volume(15, np.random.default_rng(3))
    uv = [cam.project(xyz) for cam in rig.cameras]
    with tempfile.TemporaryDirectory() as tmp, RosHarness() as ros:
        calib = str(rig.save(Path(tmp) / 'calib.yaml'))
        node = ros.start(ReconstructorNode, method=args.method, calibration_file=calib)
        pubs = [ros.publisher(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, c))
                for c in topics.CAMERAS]
        for pub in pubs:
            ros.wait_for_subscribers(pub)
        n = int(args.seconds * args.fps)
        t_start = time.monotonic()
        for k in range(n):
            t = k / args.fps
            pubs[0].publish(points_msg('cam_side', t, uv[0]))
            pubs[1].publish(points_msg('cam_front', t + 0.003, uv[1]))
            while time.monotonic() < t_start + (k + 1) / args.fps:
                ros.executor.spin_once(timeout_sec=0.002)
        ros.spin_until(lambda: node.work.waiting == 0, 30.0)
        figures = {'frames_per_camera': n, 'fps': args.fps, 'method': args.method,
                   'instants': node.counts['instants'],
                   'kept_fraction': round(node.counts['instants'] / n, 4),
                   'dropped_behind': node.work.dropped, 'unpaired': node.stream.sync.unpaired,
                   'most_waiting': node.work.most_waiting,
                   'pair_ms': round(pair_ms(calib, args.method, uv), 2)}
    print(json.dumps(figures))


if __name__ == '__main__':
    main()
