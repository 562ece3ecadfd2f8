"""Live use at 50 FPS per camera: do detection and reconstruction keep up on this machine?

Default mode: pixel points of 15 markers (the twin rig's projections) stream in real time at
``--fps`` per camera for ``--seconds`` into ``dempath_reconstructor`` (launch-free harness, one
process), as detectors would publish them. ``--images``: 1920x1080 JPEG frames of both cameras
(the rendered field recording bags/field_render_reduced_1ms, its 31 frames played forwards and
backwards with live stamps) stream with a camera driver's sensor-data QoS into one
``dempath_detector`` per camera and the reconstructor.

Figures from the nodes' own counts: ``kept_fraction`` (instants reconstructed / frame pairs
sent), ``dropped_behind`` (frames a worker dropped because it was behind), ``unpaired``,
``most_waiting`` (largest work queue), ``pair_ms`` (core cost of one pair, measured alone); with
``--images`` also per camera ``frames_in``, ``processed``, ``dropped_behind``,
``latency_ms_max`` / ``latency_ms_mean`` (arrival to publication of the pixel points) and
``detect_ms`` (one frame's detection alone), and the load average before and after. The last
line is one JSON object.

Usage: ``.venv/bin/python bench/live_rig.py [--images] [--seconds 10] [--fps 50] [--method dlt]
[--work-queue 10]``
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from std_msgs.msg import Header

from dempath import topics
from dempath.nodes.harness import RosHarness
from dempath_msgs.msg import MarkerPoints3D, PixelPoints
from dempath_recon.nodes.convert import s_to_stamp
from dempath_recon.nodes.reconstructor import ReconstructorNode
from dempath_recon.pairing import PixelFrame
from dempath_recon.stream import MarkerStream, StreamConfig
from dempath_twin.rig import paper_rig, sample_working_volume

RENDER = Path(__file__).resolve().parents[1] / 'bags' / 'field_render_reduced_1ms'


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


def render_frames() -> tuple[Any, dict[str, list[bytes]], list[dict[int, Any]]]:
    """The render's rig, its field frames per camera (JPEG bytes, after the board views), and
    the true marker positions of each frame (``{marker: xyz}``, field frame [m])."""
    from dempath.bagio import open_bag
    from dempath_calib.camera import StereoCalibration

    truth = json.loads(RENDER.with_name(RENDER.name + '.truth.json').read_text())
    start_ns = int(truth['calibration_segment']['field_start_ns'])
    topic_cam = {topics.camera_topic(topics.IMAGE_COMPRESSED, c): c for c in topics.CAMERAS}
    jpeg: dict[str, list[bytes]] = {c: [] for c in topics.CAMERAS}
    with open_bag(RENDER, list(topic_cam)) as reader:
        for raw in reader.messages(list(topic_cam)):
            msg = reader.deserialize(raw)
            if msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec >= start_ns:
                jpeg[topic_cam[raw.topic]].append(bytes(msg.data))
    xyz = [dict(zip(truth['marker_ids'], np.asarray(f['xyz']), strict=True))
           for f in truth['frames'] if f['camera'] == 'cam_side']
    return StereoCalibration.from_dict(truth['calibration_segment']['rig']), jpeg, xyz


def error_figures(points: list[Any], xyz: list[dict[int, Any]], period: int,
                  fps: float) -> dict[str, Any]:
    """Distance of the reconstructed markers from their true places at their frames [mm]."""
    errors = []
    for p in points:
        k = round((p.header.stamp.sec + 1e-9 * p.header.stamp.nanosec) * fps)
        i = k % period if k % period < len(xyz) else period - k % period
        errors += [np.linalg.norm(np.array([x, y, z]) - xyz[i][m])
                   for m, x, y, z in zip(p.marker_ids, p.x, p.y, p.z, strict=True)]
    err = 1e3 * np.asarray(errors) if errors else np.full(1, np.nan)
    return {'points': len(errors), 'error_mm_p50': round(float(np.median(err)), 2),
            'within_10mm': round(float(np.mean(err < 10.0)), 3)}


def detect_ms(rig: Any, jpeg: list[bytes]) -> float:
    """Detection and tracking of one frame alone [ms] (no ROS)."""
    from dempath_recon.tracking.stereo import StereoMarkerTracker

    core = StereoMarkerTracker({c.name: c for c in rig.cameras})
    core.update('cam_side', 0.0, jpeg[0])  # compiles and warms up
    t0 = time.perf_counter()
    for k, data in enumerate(jpeg[1:], start=1):
        core.update('cam_side', k / 50, data)
    return 1e3 * (time.perf_counter() - t0) / (len(jpeg) - 1)


def run_images(args: argparse.Namespace) -> dict[str, Any]:
    """JPEG of both cameras through two detectors and the reconstructor; the figures."""
    from rclpy.parameter import Parameter
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import CompressedImage

    from dempath_recon.nodes.detector import DetectorNode

    rig, jpeg, xyz = render_frames()
    period = 2 * len(jpeg['cam_side']) - 2
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp, RosHarness() as ros:
        calib = str(rig.save(Path(tmp) / 'calib.yaml'))
        dets = {c: ros.add(DetectorNode(context=ros.context, namespace=c, parameter_overrides=[
            Parameter('camera', value=c), Parameter('calibration_file', value=calib),
            Parameter('work_queue', value=args.work_queue)])) for c in topics.CAMERAS}
        node = ros.start(ReconstructorNode, method=args.method, calibration_file=calib)
        pubs = {c: ros.publisher(CompressedImage, topics.camera_topic(topics.IMAGE_COMPRESSED, c),
                                 qos_profile_sensor_data) for c in topics.CAMERAS}
        points = ros.collect(MarkerPoints3D, topics.MARKER_POINTS, 1000)
        for pub in pubs.values():
            ros.wait_for_subscribers(pub)
        n = int(args.seconds * args.fps)
        t_start = time.monotonic()
        for k in range(n):
            i = k % period if k % period < len(jpeg['cam_side']) else period - k % period
            for c, offset in zip(topics.CAMERAS, (0.0, 0.003), strict=True):
                msg = CompressedImage(format='jpeg', data=jpeg[c][i])
                msg.header.stamp = s_to_stamp(k / args.fps + offset)
                pubs[c].publish(msg)
            while time.monotonic() < t_start + (k + 1) / args.fps:
                ros.executor.spin_once(timeout_sec=0.002)
        ros.spin_until(lambda: all(d.work.waiting == 0 for d in dets.values())
                       and node.work.waiting == 0, 60.0)
        ros.spin_for(0.5)  # frames the starved executor had not yet taken off the middleware
        ros.spin_until(lambda: all(d.work.waiting == 0 for d in dets.values())
                       and node.work.waiting == 0, 30.0)
        cams = {}
        for c, d in dets.items():
            f = d.figures()
            cams[c] = {k: f[k] for k in ('frames_in', 'missing_in', 'processed', 'skipped',
                                         'dropped_behind', 'dropped_stale', 'failed',
                                         'waiting', 'most_stride', 'most_waiting',
                                         'latency_ms_max', 'latency_ms_mean')}
        figures = {'mode': 'images', 'frames_per_camera': n, 'fps': args.fps,
                   'method': args.method, 'work_queue': args.work_queue,
                   'instants': node.counts['instants'],
                   'kept_fraction': round(node.counts['instants'] / n, 4),
                   'detected_fraction': round(sum(v['processed'] for v in cams.values())
                                              / (2 * n), 4),
                   'recon_dropped_behind': node.work.dropped,
                   'unpaired': node.stream.sync.unpaired, 'cameras': cams,
                   **error_figures(points, xyz, period, args.fps)}
    figures['detect_ms'] = round(detect_ms(rig, jpeg['cam_side']), 2)
    figures['load_before'] = [round(v, 2) for v in load_before]
    figures['load_after'] = [round(v, 2) for v in os.getloadavg()]
    return figures


def main() -> None:
    """Stream, settle, print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--images', action='store_true',
                        help='1920x1080 JPEG through the detectors (default: pixel points)')
    parser.add_argument('--seconds', type=float, default=10.0)
    parser.add_argument('--fps', type=float, default=50.0)
    parser.add_argument('--method', default='dlt')
    parser.add_argument('--work-queue', type=int, default=10,
                        help="the detectors' work queue [frames]")
    args = parser.parse_args()
    if args.images:
        print(json.dumps(run_images(args)))
        return
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
        figures = {'mode': 'pixel_points', 'frames_per_camera': n, 'fps': args.fps,
                   'method': args.method,
                   'instants': node.counts['instants'],
                   'kept_fraction': round(node.counts['instants'] / n, 4),
                   'dropped_behind': node.work.dropped, 'unpaired': node.stream.sync.unpaired,
                   'most_waiting': node.work.most_waiting,
                   'pair_ms': round(pair_ms(calib, args.method, uv), 2)}
    print(json.dumps(figures))


if __name__ == '__main__':
    main()
