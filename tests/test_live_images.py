"""Live use from camera images: 1920x1080 JPEG at 50 FPS per camera, no bag, through detection
and reconstruction in real time.

The rendered field recording's 31 frames per camera (bags/field_render_reduced_1ms, the twin rig
at 1920x1080, JPEG 85) are played forwards and backwards in a loop with live stamps (frame k at
k / 50 s, the front camera 3 ms later) on the cameras' CompressedImage topics with a camera
driver's sensor-data QoS, together with the tool's pose of the paper's 1.5 m/s pass. A detector
node per camera and the reconstructor run in this process, as on a tractor's computer.

Detection costs about 10 ms of CPU per frame and the machine has two cores, so the detectors may
not keep up with 100 frames/s: the test checks the accounting, not the speed (that is
bench/live_rig.py's ``--images`` figure). Every frame sent reaches a detector; each is detected or
dropped by the work queue and counted; the count of frames dropped behind equals the frames the
detector saw missing by their stamps (two independent counts); the queues never grow past their
bounds; the pass is found from the tool's motion; the 3D points that come out are the markers of
the frames they were detected in. A camera that stops mid-pass aborts the pass with one line
naming it, and nothing measured before is lost.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import CompressedImage
from std_msgs.msg import Header

from dempath import topics
from dempath_calib.camera import StereoCalibration
from dempath_msgs.msg import MarkerPoints3D, PixelPoints, RunEvent
from dempath_recon.nodes.convert import s_to_stamp, stamp_to_s
from dempath_recon.nodes.detector import DetectorNode
from dempath_recon.nodes.passgate import PassNode
from dempath_recon.nodes.reconstructor import ReconstructorNode
from dempath_sim.scene.profiles import PAPER_1_5MS

from .render_frames import field_images

pytestmark = pytest.mark.timeout(300)
ROOT = Path(__file__).resolve().parents[1]
RENDER = ROOT / 'bags' / 'field_render_reduced_1ms'
TRUTH = RENDER.with_name(RENDER.name + '.truth.json')
FPS = 50.0
FRONT_OFFSET_S = 0.003  # the render's front camera exposes 3 ms after the side one
WORK_QUEUE = 10  # the detectors' work queue [frames]
SLOP_S = 0.01


class Render:
    """The recording's field frames per camera (JPEG bytes), their true markers, the rig."""

    def __init__(self) -> None:
        truth = json.loads(TRUTH.read_text())
        self.rig = StereoCalibration.from_dict(truth['calibration_segment']['rig'])
        self.jpeg: dict[str, list[bytes]] = {c: [] for c in topics.CAMERAS}
        for cam, _, msg in field_images(RENDER):
            self.jpeg[cam].append(bytes(msg.data))
        side = [f for f in truth['frames'] if f['camera'] == 'cam_side']
        self.xyz = [np.asarray(f['xyz'], np.float64) for f in side]  # (15, 3) per frame [m]
        self.ids = np.asarray(truth['marker_ids'])
        front = [f for f in truth['frames'] if f['camera'] == 'cam_front']
        # per frame: how many markers both cameras see at least half of (the rest may be buried)
        self.both_visible = [int(np.sum((np.asarray(a['visible']) > 0.5)
                                        & (np.asarray(b['visible']) > 0.5)))
                             for a, b in zip(side, front, strict=True)]
        assert len(self.jpeg['cam_side']) == len(self.jpeg['cam_front']) == len(side) > 10

    def index(self, k: int) -> int:
        """The recorded frame shown as live frame ``k``: forwards, backwards, forwards..."""
        n = len(self.xyz)
        i = k % (2 * n - 2)
        return i if i < n else 2 * n - 2 - i


@pytest.fixture(scope='module')
def render() -> Render:
    """The bundled render, read once."""
    return Render()


def tool_z(t: float) -> float:
    """The paper's 1.5 m/s pass (profile 2, sec. 2.3) after 1 s standing still [m]."""
    return float(PAPER_1_5MS.distance(max(t - 1.0, 0.0)))


def image(stamp_s: float, data: bytes) -> CompressedImage:
    """A camera driver's compressed frame."""
    return CompressedImage(header=Header(stamp=s_to_stamp(stamp_s)), format='jpeg', data=data)


def pose(stamp_s: float, z: float) -> PoseStamped:
    """The tool's pose from the tractor."""
    msg = PoseStamped()
    msg.header.stamp = s_to_stamp(stamp_s)
    msg.pose.position.z = z
    msg.pose.orientation.w = 1.0
    return msg


class Graph:
    """Two detectors, the reconstructor and the pass node; probe publishers and collectors."""

    def __init__(self, ros: Any, render: Render, tmp_path: Path,
                 camera_timeout_s: float = 3.0) -> None:
        # a camera counts as stopped mid-pass when its detector publishes nothing for
        # camera_timeout_s: more than the detector's latency bound (max_wait_s 0.5 s plus one
        # detection, over 1 s on this 2-core machine when other work loads it)
        calib = str(render.rig.save(tmp_path / 'calib.yaml'))
        self.ros = ros
        self.points = ros.collect(MarkerPoints3D, topics.MARKER_POINTS, 1000)
        self.diags = ros.collect(DiagnosticArray, topics.DIAGNOSTICS, 100)
        self.events = ros.collect(RunEvent, topics.PASS_EVENTS)
        # two nodes of one class: each detector in its camera's namespace, as the demo's
        self.detectors = {c: ros.add(DetectorNode(
            context=ros.context, namespace=c, parameter_overrides=[
                Parameter('camera', value=c), Parameter('calibration_file', value=calib),
                Parameter('work_queue', value=WORK_QUEUE),
                Parameter('diagnostics_period_s', value=0.5),
                Parameter('silent_s', value=0.5)])) for c in topics.CAMERAS}
        self.recon = ros.start(ReconstructorNode, method='dlt', slop=SLOP_S,
                               calibration_file=calib)
        ros.start(PassNode, trigger='tool_motion', camera_timeout_s=camera_timeout_s)
        self.images = {c: ros.publisher(CompressedImage,
                                        topics.camera_topic(topics.IMAGE_COMPRESSED, c),
                                        qos_profile_sensor_data) for c in topics.CAMERAS}
        self.tool = ros.publisher(PoseStamped, topics.TOOL_POSE, qos_profile_sensor_data)
        for pub in [*self.images.values(), self.tool]:
            assert ros.wait_for_subscribers(pub)
        for c in topics.CAMERAS:  # reconstructor, pass node and the other detector listen
            pub = self.detectors[c].pub
            assert ros.spin_until(lambda p=pub: p.get_subscription_count() >= 3, 10.0)

    def send(self, render: Render, k: int, front: bool = True) -> None:
        """Frame ``k`` of both cameras (or the side one only) and the tool's pose."""
        t, i = k / FPS, render.index(k)
        self.tool.publish(pose(t, tool_z(t)))
        self.images['cam_side'].publish(image(t, render.jpeg['cam_side'][i]))
        if front:
            self.images['cam_front'].publish(
                image(t + FRONT_OFFSET_S, render.jpeg['cam_front'][i]))

    def stream(self, render: Render, n: int, stop_front_after_s: float = 1e9) -> int:
        """Publish ``n`` frames of both cameras at FPS in real time; return ``n``."""
        t_start = time.monotonic()
        for k in range(n):
            self.send(render, k, front=k / FPS < stop_front_after_s)
            while time.monotonic() < t_start + (k + 1) / FPS:
                self.ros.executor.spin_once(timeout_sec=0.002)
        return n

    def counts(self, name: str) -> dict[str, float]:
        """The last published counts of the status called ``name``."""
        for msg in reversed(self.diags):
            for s in msg.status:
                if s.name == name:
                    return {kv.key: float(kv.value) for kv in s.values}
        return {}

    def status(self, name: str) -> Any:
        """The last published status called ``name``."""
        return next(s for msg in reversed(self.diags) for s in msg.status if s.name == name)


def marker_errors_mm(render: Render, msg: MarkerPoints3D) -> np.ndarray:
    """Distance of each reconstructed marker from its true position at the frame's stamp [mm]."""
    k = round(stamp_to_s(msg.header.stamp) * FPS)
    truth = dict(zip(render.ids.tolist(), render.xyz[render.index(k)], strict=True))
    return np.array([1e3 * np.linalg.norm(np.array([x, y, z]) - truth[m])
                     for m, x, y, z in zip(msg.marker_ids, msg.x, msg.y, msg.z, strict=True)])


DET = 'dempath_detector: {}'
RECON = 'dempath_reconstructor: reconstruction'


def test_live_jpeg_at_50_fps_through_detection_and_reconstruction(
        ros_harness, render: Render, tmp_path: Path) -> None:
    """10 s of 1920x1080 JPEG at 50 FPS per camera: every frame accounted for, queues bounded."""
    g = Graph(ros_harness, render, tmp_path)
    n = g.stream(render, 504)  # 10.08 s
    # once the queues have drained, frame 504 (a multiple of every stride, 1, 2, ... 8) closes
    # the run: the detectors detect it, so every frame skipped or dropped before it is a gap in
    # the stamps of the frames they detected
    assert ros_harness.spin_until(lambda: all(
        d.work.waiting == 0 for d in g.detectors.values()), 30.0)
    g.send(render, n)
    n += 1
    sent = {'cam_side': n, 'cam_front': n}

    def settled() -> bool:
        det = {c: g.counts(DET.format(c)) for c in topics.CAMERAS}
        rec = g.counts(RECON)
        return all(d.get('frames_in', 0) + d['missing_in'] == n and d['waiting'] == 0
                   for d in det.values()) \
            and bool(rec) and rec['waiting'] == 0 and rec['instants'] == len(g.points) \
            and rec['frames_side'] == det['cam_side']['published'] \
            and rec['frames_front'] == det['cam_front']['published']

    assert ros_harness.spin_until(settled, 60.0), [g.counts(DET.format(c)) for c in sent]
    figures = {}
    for cam in topics.CAMERAS:
        d = g.counts(DET.format(cam))
        figures[cam] = {k: d[k] for k in ('frames_in', 'missing_in', 'processed', 'skipped',
                                          'dropped_behind', 'dropped_stale', 'most_stride',
                                          'gap_frames', 'detected', 'tracked', 'lost',
                                          'most_waiting', 'most_behind', 'latency_ms_max',
                                          'latency_ms_mean')}
        # best effort, as from a camera driver: frames the middleware lost on a loaded machine
        # show as gaps in the arriving stamps (the last frame, detected, closes every gap)
        assert d['frames_in'] + d['missing_in'] == sent[cam], f'{cam}: frames unaccounted: {d}'
        assert d['processed'] + d['skipped'] + d['dropped_behind'] + d['dropped_stale'] \
            == d['frames_in'], f'{cam}: frames unaccounted for: {d}'
        assert d['undecodable'] == d['failed'] == d['out_of_order'] == 0, d
        assert d['published'] == d['frames'] == d['processed'], d
        # the frames the node skipped or dropped are exactly the gaps the tracker saw in the
        # stamps of the frames it detected: two independent counts
        assert d['gap_frames'] == d['missing_in'] + d['skipped'] + d['dropped_behind'] \
            + d['dropped_stale'], d
        assert d['most_waiting'] <= WORK_QUEUE and d['most_behind'] <= WORK_QUEUE, d
        assert d['tracked'] > 0, f'{cam}: no marker tracked: {d}'
        status = g.status(DET.format(cam))
        # WARN for a fault, or for a camera silent longer than silent_s: the stream has ended,
        # so a status published after the last frame may say so (a race with `settled`)
        silent = status.message.startswith('no frame for ')
        assert (status.level == status.WARN) == (d['gap_frames'] > 0 or silent), status.message
    r = g.counts(RECON)
    figures['reconstructor'] = {k: r[k] for k in ('instants', 'unpaired', 'dropped_behind')}
    print(json.dumps(figures))
    assert 2 * r['instants'] + r['unpaired'] + r['waiting_partner'] + r['dropped_behind'] \
        == r['frames_side'] + r['frames_front'], f'frames unaccounted for: {r}'
    assert r['most_waiting'] <= 100 and r['dropped'] == 0, r
    assert r['instants'] > 0, r  # how many pair up depends on the machine: the bench's figure
    # the 3D frames hold the markers of the recorded frames their images came from
    errors = {round(stamp_to_s(p.header.stamp) * FPS): marker_errors_mm(render, p)
              for p in g.points}
    first = errors[min(errors)]
    every = np.concatenate(list(errors.values()))
    print(json.dumps({'first_instant': min(errors), 'first_errors_mm': first.round(2).tolist(),
                      'points': len(every), 'error_mm_p50_p90_p99':
                      np.percentile(every, [50, 90, 99]).round(2).tolist(),
                      'within_10mm': round(float(np.mean(every < 10.0)), 3)}))
    # the first instant (numbered by the marker grid) is measured to the markers' true places;
    # later ones depend on tracking across the frames this machine could not detect in time,
    # whose figures are bench/live_rig.py --images's
    seen = render.both_visible[render.index(min(errors))]
    # (a marker half covered by grains is found off its true centre: a few mm, not tens)
    assert len(first) >= seen and np.median(first) < 2.0 and first.max() < 5.0, (first, seen)
    assert [(e.run_id, e.event) for e in g.events] == [('pass_1', RunEvent.STARTED),
                                                       ('pass_1', RunEvent.FINISHED)]


def test_camera_images_stopping_mid_pass(ros_harness, render: Render, tmp_path: Path) -> None:
    """The front camera's images stop 2 s in: one line naming it, nothing measured lost."""
    g = Graph(ros_harness, render, tmp_path, camera_timeout_s=3.0)
    n = g.stream(render, 400, stop_front_after_s=2.0)  # the side camera goes on to 8 s
    assert ros_harness.spin_until(lambda: len(g.events) == 2, 10.0), [e.detail for e in g.events]
    assert g.events[0].event == RunEvent.STARTED
    assert g.events[1].event == RunEvent.ABORTED
    assert g.events[1].detail == ('cam_front: no frame for more than 3.0 s mid-pass; pass_1 '
                                  'ends incomplete')

    def settled() -> bool:
        det = [g.counts(DET.format(c)) for c in topics.CAMERAS]
        rec = g.counts(RECON)
        return all(d and d['waiting'] == 0 for d in det) and bool(rec) \
            and 'no frame for' in g.status(DET.format('cam_front')).message \
            and rec['waiting'] == 0 and rec['instants'] == len(g.points) \
            and rec['frames_side'] == det[0]['published'] \
            and rec['frames_front'] == det[1]['published']

    assert ros_harness.spin_until(settled, 30.0), [g.counts(DET.format(c)) for c in
                                                   topics.CAMERAS]
    for cam in topics.CAMERAS:  # every frame that reached a detector accounted for
        d = g.counts(DET.format(cam))
        assert d['processed'] + d['skipped'] + d['dropped_behind'] + d['dropped_stale'] \
            == d['frames_in'] <= (n if cam == 'cam_side' else 100), d
    assert g.status(DET.format('cam_front')).level == DiagnosticStatus.WARN
    r = g.counts(RECON)
    assert r['instants'] > 0 and r['unpaired'] + r['waiting_partner'] > 0, r  # side frames alone
    assert 2 * r['instants'] + r['unpaired'] + r['waiting_partner'] + r['dropped_behind'] \
        == r['frames_side'] + r['frames_front'], r


def test_raw_images_that_do_not_fit_are_counted(ros_harness, render: Render, tmp_path: Path,
                                                capfd: pytest.CaptureFixture[str]) -> None:
    """sensor_msgs/Image from a driver: a good bgr8 frame is detected; a truncated one and an
    unsupported encoding each give one error line naming the fault, are counted as failed, and
    the node goes on."""
    import cv2
    from sensor_msgs.msg import Image

    calib = str(render.rig.save(tmp_path / 'calib.yaml'))
    node = ros_harness.start(DetectorNode, camera='cam_side', calibration_file=calib,
                             compressed=False, lossless=True)
    got = ros_harness.collect(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, 'cam_side'))
    pub = ros_harness.publisher(Image, topics.camera_topic(topics.IMAGE_RAW, 'cam_side'))
    assert ros_harness.wait_for_subscribers(pub)
    bgr = cv2.imdecode(np.frombuffer(render.jpeg['cam_side'][0], np.uint8), cv2.IMREAD_COLOR)
    h, w = bgr.shape[:2]
    frames = [('bgr8', bgr.tobytes()), ('bgr8', bgr.tobytes()[:w * 3 * 100]),
              ('mono16', bgr.tobytes()), ('bgr8', bgr.tobytes())]
    for k, (encoding, data) in enumerate(frames):
        pub.publish(Image(header=Header(stamp=s_to_stamp(k / FPS)), height=h, width=w,
                          encoding=encoding, step=w * 3, data=data))
        ros_harness.spin_for(0.05)
    assert ros_harness.spin_until(lambda: len(got) == 2 and node.work.waiting == 0, 30.0)
    f = node.figures()
    assert (f['frames_in'], f['processed'], f['failed'], f['published']) == (4, 4, 2, 2), f
    assert len(got[0].marker_ids) >= render.both_visible[0]
    err = capfd.readouterr().err
    assert err.count('cam_side frame at 0.020000 s: ValueError: 576000 bytes do not fit '
                     '1920x1080, step 5760; skipped (counted as failed)') == 1, err
    assert err.count("cam_side frame at 0.040000 s: ValueError: encoding 'mono16' (bgr8 or rgb8 "
                     'expected); skipped (counted as failed)') == 1, err
