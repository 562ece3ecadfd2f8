"""Marker detection node, one per camera: images -> numbered dempath_msgs/PixelPoints.

Subscribes ``/<camera>/image_raw/compressed`` (``sensor_msgs/CompressedImage``, or
``/<camera>/image_raw`` ``sensor_msgs/Image`` bgr8/rgb8 with ``compressed:=false``) with
sensor-data QoS (best effort, so that it matches camera drivers and a reliable player alike), and
the other camera's ``pixel_points`` (for numbering markers by the epipolar line); numbers the
markers first by the marker grid (``scene``, or ``marker_rows`` / ``marker_columns`` /
``marker_spacing_x_m`` / ``marker_spacing_z_m`` / ``marker_side``; the paper's 3 x 5 at 50 mm by
default) projected through the calibration; publishes
``/<camera>/pixel_points`` with ``SOURCE_DETECTED`` and the detector's confidence; only numbered
markers are published (the reconstructor pairs by number).

Live cameras deliver frames faster than a loaded machine may detect them, so the image callback
only counts and enqueues; a worker thread detects (:class:`dempath.workqueue.WorkQueue`). When
the worker falls behind, the callback first detects only every 2nd, 4th, ... frame by stamp, up
to ``max_stride`` (:class:`FrameStride`: the two cameras' detectors then keep frames of the same
instants, which the reconstructor needs), counted as ``skipped``; when the worker is still more
than ``work_queue`` frames behind, the oldest waiting frame is dropped and counted
(``dropped_behind``), and a frame that waited longer than ``max_wait_s`` is dropped and counted
(``dropped_stale``): the latency stays bounded at ``max_wait_s`` plus one detection, and no frame
disappears unseen. With ``lossless:=true`` (playing a bag, as the demo does) the subscription
is reliable and keeps all, and every frame is detected: no stride, no drop, no age limit.
With ``lossless`` the node also subscribes the other camera's images and runs the two-camera
tracker on both, in the order of their stamps (:class:`~dempath_recon.tracking.merge.StampMerge`:
a frame is tracked once the other camera has a frame stamped later; after ``merge_wait_s``
without any image, the rest), with the tracker's publication delay, and publishes its own
camera's frames: the numbers are those of the offline ``track_bag`` on the same bag, whatever
order the two topics' messages arrive in (the nodes' output does not depend on the machine's
load; a pause of the player longer than ``merge_wait_s`` would be taken for the end). A camera
that stops leaves the other's frames waiting until the recording ends. It costs the other
camera's decoding and detection too.

Every ``diagnostics_period_s`` the node publishes on ``/diagnostics``:
``frames_in`` (arrived), ``missing_in`` (never arrived: gaps in the arriving stamps, frames lost
by the camera, the network or the middleware's best-effort queue), ``processed`` (through the
detector, bad ones included), ``skipped``, ``stride``, ``most_stride``, ``dropped_behind``,
``dropped_stale``, ``waiting``, ``most_waiting``, ``latency_ms_max`` / ``latency_ms_mean`` (from
arrival to publication), ``most_behind`` (frames enqueued while a frame waited for the worker:
the queueing delay in frames, at most ``work_queue``), ``failed`` (raw images that do not fit
their header, or a detection error), and the detector's counts (``undecodable``, ``gap_frames``:
frames missing between the detected frames' stamps, whatever the reason, ``out_of_order``,
``detected``, ``tracked``, ``lost``, ...). Always ``frames_in = processed + skipped +
dropped_behind + dropped_stale + waiting``.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from numpy.typing import NDArray
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CompressedImage, Image

from dempath import topics
from dempath.nodes.spin import run_node
from dempath.workqueue import WorkQueue
from dempath_msgs.msg import PixelPoints
from dempath_recon.errors import ReconstructionError
from dempath_recon.stride import FrameStride
from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.colour_model import parse_bgr
from dempath_recon.tracking.detect import DetectorConfig
from dempath_recon.tracking.merge import StampMerge
from dempath_recon.tracking.stereo import PixelFrame, StereoMarkerTracker, StereoTrackConfig

PARAMETERS: tuple[tuple[str, Any, str], ...] = (
    ('camera', 'cam_side', 'camera whose images this node detects in (cam_side, cam_front)'),
    ('calibration_file', '', 'stereo calibration YAML (dempath_calib) [path], required'),
    ('compressed', True, 'subscribe CompressedImage (true) or Image (false)'),
    ('diagnostics_period_s', 1.0, 'period of the diagnostics message [s]'),
    ('work_queue', 10, 'frames waiting for detection before the oldest is dropped and counted'),
    ('max_wait_s', 0.5, 'a frame that waited longer for the worker is dropped and counted '
                        '(dropped_stale) [s]; 0: no limit'),
    ('fps', 50.0, "the cameras' nominal frame rate (frame numbers from stamps) [1/s]"),
    ('max_stride', 8, 'when behind, detect only every 2nd, 4th, ... frame by stamp, up to this'),
    ('subscription_depth', 10, 'frames the middleware keeps on the image topic (best effort)'),
    ('lossless', False, 'bag playback: reliable keep-all subscription, every frame detected (no '
                        'stride, no drop, no age limit)'),
    ('merge_wait_s', 2.0, 'lossless: after this long without an image of either camera, the '
                          'frames still waiting for the other camera are tracked and the held '
                          'ones published (the end of a recording) [s]'),
    ('silent_s', 1.0, 'no frame for this long after the first: diagnostics say WARN [s]'),
    ('correct_shake', True, "move each frame's detections back by the image's shake, measured "
                            'on the parts of the view that do not move (tracking/shake.py)'),
    ('marker_bgr', '', "the markers' clay albedo B,G,R (0..1 each, e.g. '0.15,0.18,0.62' for "
                       "red clay); '': blue clay (tracking/colour_model.py)"),
    ('tool_speed_m_s', 0.0, "the tool's speed [m/s]: no frame-to-frame link moves a marker "
                            'farther than it can go at 1.2x that (tracking/speed_bound.py); '
                            '0: not known, no bound'),
    ('publish_gate', True, "lossless: withhold a numbered point whose pair's 3D point jumps "
                           "unlike its neighbours' motion (tracking/publish_gate.py)"),
    ('whole_pass', True, 'lossless: hold every frame till the recording ends, then number the '
                         'tracks no rule numbered from the whole pass (tracking/whole_pass.py, '
                         'as the offline path); false: publish as frames are due'),
    ('scene', '', "scene file or shipped scene name whose markers: block gives the marker grid "
                  "(overrides the marker_* parameters); '': the marker_* parameters"),
    ('marker_rows', 3, 'rows of the marker grid (row 0 on the tool axis; the paper: 3)'),
    ('marker_columns', 5, 'markers per row, in travel order (the paper: 5)'),
    ('marker_spacing_x_m', 0.05, 'grid pitch across the travel, X [m]'),
    ('marker_spacing_z_m', 0.05, 'grid pitch along the travel, Z [m]'),
    ('marker_side', 1, 'side of the tool axis the further rows lie on (+1: +X, -1: -X)'),
)
OTHER_KEPT = 200  # the other camera's frames waiting to be noted by the worker
LOSSLESS_QUEUE = 1_000_000  # frames that may wait when playing a bag losslessly


@dataclass
class _Arrival:
    """An image as it came off the subscription."""

    msg: CompressedImage | Image | None  # None: release what waited merge_wait_s
    arrived_s: float  # monotonic clock at the callback [s]
    index: int  # frames enqueued, this one included
    camera: str = ''  # whose image (lossless: either camera)


@dataclass
class Latency:
    """Arrival-to-publication delay of the published frames (whole run and current window)."""

    max_s: float = 0.0
    sum_s: float = 0.0
    n: int = 0
    most_behind: int = 0  # frames enqueued while one frame waited for the worker

    def add(self, delay_s: float, behind: int) -> None:
        """One published frame."""
        self.max_s = max(self.max_s, delay_s)
        self.sum_s += delay_s
        self.n += 1
        self.most_behind = max(self.most_behind, behind)

    def figures(self) -> dict[str, float | int]:
        """``latency_ms_max``, ``latency_ms_mean``, ``most_behind``."""
        mean = self.sum_s / self.n if self.n else 0.0
        return {'latency_ms_max': round(1e3 * self.max_s, 2),
                'latency_ms_mean': round(1e3 * mean, 2), 'most_behind': self.most_behind}


class DetectorNode(Node):
    """Thin adapter around :class:`dempath_recon.tracking.stereo.StereoMarkerTracker`."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_detector', **kwargs)
        self.declare_parameters('', [(name, default, ParameterDescriptor(description=text))
                                     for name, default, text in PARAMETERS])
        p = {name: self.get_parameter(name).value for name, _, _ in PARAMETERS}
        self.camera = str(p['camera'])
        self.core = StereoMarkerTracker(_load_cameras(str(p['calibration_file'])),
                                        _track_config(p))
        if self.camera not in self.core.cameras:
            msg = f'camera: {self.camera!r} not in the calibration ({sorted(self.core.cameras)})'
            raise ReconstructionError(msg)
        self.other = self.core.other(self.camera)
        self.silent_s = float(p['silent_s'])
        lossless = bool(p['lossless'])
        self.counts = {'frames_in': 0, 'published': 0, 'failed': 0, 'dropped_stale': 0}
        self.max_wait_s = 0.0 if lossless else float(p['max_wait_s'])
        self.latency = Latency()
        self.last_arrival_s: float | None = None
        self.enqueued = 0  # frames handed to the worker
        self.others: deque[PixelPoints] = deque(maxlen=OTHER_KEPT)  # numbering hints only
        bound = LOSSLESS_QUEUE if lossless else int(p['work_queue'])
        self.work: WorkQueue[_Arrival] = WorkQueue(self.work_on, bound, f'detector_{self.camera}')
        self.stride = FrameStride(float(p['fps']), 1 if lossless else int(p['max_stride']), bound)
        self.pub = self.create_publisher(
            PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, self.camera), 10)
        self.pub_diag = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, 10)
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(p['subscription_depth']),
                         reliability=ReliabilityPolicy.BEST_EFFORT)
        if lossless:  # a player's burst waits in the middleware (flow control), none replaced
            qos = QoSProfile(history=HistoryPolicy.KEEP_ALL,
                             reliability=ReliabilityPolicy.RELIABLE)
        if p['compressed']:
            self.create_subscription(
                CompressedImage, topics.camera_topic(topics.IMAGE_COMPRESSED, self.camera),
                self.enqueue, qos)
        else:
            self.create_subscription(Image, topics.camera_topic(topics.IMAGE_RAW, self.camera),
                                     self.enqueue, qos)
        self.create_subscription(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, self.other),
                                 self.on_other, 10)
        self.merge: StampMerge[_Arrival] | None = None
        self.merge_lock = threading.Lock()  # the worker and the timer look at the merge
        self.merge_wait_s = float(p['merge_wait_s'])
        self.headers: dict[float, tuple[Any, float, int]] = {}  # own frames held by the core
        self.last_any_s = time.monotonic()
        if lossless:  # both cameras' images, one tracker, in stamp order
            self.merge = StampMerge(self.core.cameras)
            self.counts['other_frames_in'] = 0
            kind, topic = ((CompressedImage, topics.IMAGE_COMPRESSED) if p['compressed']
                           else (Image, topics.IMAGE_RAW))
            self.create_subscription(kind, topics.camera_topic(topic, self.other),
                                     self.enqueue_other, qos)
            self.create_timer(0.1, self.check_waiting)
        self.create_timer(float(p['diagnostics_period_s']), self.publish_diagnostics)

    def enqueue(self, msg: CompressedImage | Image) -> None:
        """Subscription callback: count the frame and hand it to the worker (nothing slow)."""
        self.counts['frames_in'] += 1
        self.last_arrival_s = time.monotonic()
        stride = self.stride.stride
        if not self.stride.keep(_stamp_s(msg), self.work.waiting):
            return
        if self.stride.stride != stride:
            self.get_logger().info(
                f'{self.camera}: detecting every {self.stride.stride} frame(s) by stamp (was '
                f'{stride}); skipped frames are counted', throttle_duration_sec=5.0)
        self.enqueued += 1
        self.last_any_s = self.last_arrival_s
        self.work.put(_Arrival(msg, self.last_arrival_s, self.enqueued, self.camera))

    def enqueue_other(self, msg: CompressedImage | Image) -> None:
        """The other camera's image (``lossless``): to the worker, for the joint tracker."""
        self.counts['other_frames_in'] += 1
        self.last_any_s = time.monotonic()
        self.work.put(_Arrival(msg, self.last_any_s, self.enqueued, self.other))

    def check_waiting(self) -> None:
        """Timer (``lossless``): wake the worker when the merge waits for a camera that sent
        nothing for ``merge_wait_s``, or frames are held and nothing arrived for that long."""
        assert self.merge is not None
        now = time.monotonic()
        with self.merge_lock:
            stalled = len(self.merge) > 0 and self.stalled(now, self.work.waiting)
        idle = now - self.last_any_s > self.merge_wait_s
        if stalled or (idle and self.core.held() and not self.work.waiting):
            self.work.put(_Arrival(None, now, self.enqueued))

    def on_other(self, msg: PixelPoints) -> None:
        """The other camera's numbered markers: kept for the worker (which owns the tracker)."""
        self.others.append(msg)

    def work_on(self, item: _Arrival) -> None:
        """Worker thread: note the other camera's markers, detect, publish; count any failure."""
        if self.merge is not None:
            self.work_in_stamp_order(item)
            return
        assert item.msg is not None
        behind = self.enqueued - item.index
        if self.max_wait_s > 0 and time.monotonic() - item.arrived_s > self.max_wait_s:
            self.counts['dropped_stale'] += 1
            return
        while self.others:
            self.note_other(self.others.popleft())
        try:
            if isinstance(item.msg, CompressedImage):
                frame = self.core.update(self.camera, _stamp_s(item.msg), bytes(item.msg.data))
            else:
                frame = self.core.update_image(self.camera, _stamp_s(item.msg),
                                               _bgr(item.msg))
        except Exception as err:  # a live node counts a bad frame, says why, and goes on
            self.counts['failed'] += 1
            self.get_logger().error(f'{self.camera} frame at {_stamp_s(item.msg):.6f} s: '
                                    f'{type(err).__name__}: {err}; skipped (counted as failed)')
            return
        self.publish(frame, item.msg.header)
        self.latency.add(time.monotonic() - item.arrived_s, behind)

    def work_in_stamp_order(self, item: _Arrival) -> None:
        """Worker thread (``lossless``): track both cameras' frames in stamp order, publish this
        camera's frames as the tracker releases them."""
        assert self.merge is not None
        now = time.monotonic()
        with self.merge_lock:
            due = [] if item.msg is None else self.merge.push(item.camera, _stamp_s(item.msg),
                                                              item)
            while len(self.merge) and self.stalled(now, self.work.waiting - 1):
                due.append(self.merge.pop_earliest())
            left = len(self.merge)
        for camera, stamp_s, arrival in due:
            assert arrival.msg is not None
            if camera == self.camera:
                self.headers[stamp_s] = (arrival.msg.header, arrival.arrived_s,
                                         self.enqueued - arrival.index)
            held = self.core.held()
            try:
                if isinstance(arrival.msg, CompressedImage):
                    frame = self.core.update(camera, stamp_s, bytes(arrival.msg.data))
                else:
                    frame = self.core.update_image(camera, stamp_s, _bgr(arrival.msg))
            except Exception as err:  # a live node counts a bad frame, says why, and goes on
                if camera == self.camera:
                    self.headers.pop(stamp_s, None)
                    self.counts['failed'] += 1
                self.get_logger().error(f'{camera} frame at {stamp_s:.6f} s: '
                                        f'{type(err).__name__}: {err}; skipped (counted as '
                                        'failed)')
                continue
            if self.core.held() == held:  # not held (undecodable, out of order): out now
                self.publish_released([frame])
            self.publish_released(self.core.release())
        if item.msg is None and not left and now - self.last_any_s > self.merge_wait_s:
            self.publish_released(self.core.flush())  # the recording ended (or paused)

    def stalled(self, now: float, queued: int) -> bool:
        """Whether the frames left in the merge can go: no image of either camera for
        ``merge_wait_s`` and nothing else (``queued``) waiting for the worker (the recording
        ended, or a camera stopped and the other's frames wait for it; waiting for one camera
        alone would take a slow delivery for a stop and change the order)."""
        return not queued and now - self.last_any_s > self.merge_wait_s

    def publish_released(self, frames: list[PixelFrame]) -> None:
        """Publish the released frames of this camera under their own headers."""
        for frame in frames:
            held = self.headers.pop(frame.stamp_s, None) if frame.camera == self.camera \
                else None
            if held is None:
                continue
            header, arrived_s, behind = held
            self.publish(frame, header)
            self.latency.add(time.monotonic() - arrived_s, behind)

    def note_other(self, msg: PixelPoints) -> None:
        """Remember the other camera's numbered markers (for epipolar numbering; not with
        ``lossless``, where this node tracks the other camera's images itself)."""
        if self.merge is not None:
            return
        self.core.note_other(self.other, _stamp_s(msg), np.asarray(msg.marker_ids, np.int32),
                             np.column_stack([msg.u, msg.v]).astype(np.float64))

    def publish(self, frame: PixelFrame, header: Any) -> None:
        """PixelPoints of the numbered markers; log the frame's events."""
        for event in frame.events:
            self.get_logger().info(event)
        keep = frame.markers >= 0
        out = PixelPoints(header=header)
        out.header.frame_id = self.camera
        out.marker_ids = [int(m) for m in frame.markers[keep]]
        out.u = frame.uv[keep, 0].tolist()
        out.v = frame.uv[keep, 1].tolist()
        out.confidence = frame.confidence[keep].astype(np.float32).tolist()
        out.source = [PixelPoints.SOURCE_DETECTED] * int(keep.sum())
        self.pub.publish(out)
        self.counts['published'] += 1

    def tracking_counts(self) -> dict[str, Any]:
        """This camera's detection and tracking counts so far: frames, detected, tracked, lost,
        reattached and the faults (dropped, undecodable, out_of_order, no_marker, unnumbered)."""
        return dict(self.core.report()[self.camera])

    def handled_frames(self) -> int:
        """Frames the worker has finished with, skipped ones (undecodable, out of order,
        failed) included: whoever waits for the detector waits for this count. With
        ``lossless`` a frame is finished when it is published (the tracker holds frames for
        its publication delay, and the last ones until the recording ends)."""
        if self.merge is not None:
            return int(self.counts['published'] + self.counts['failed'])
        return self.processed_frames()

    def processed_frames(self) -> int:
        """Frames through the tracker, bad ones included."""
        c = self.core.counts[self.camera]
        return int(c.frames + c.undecodable + c.out_of_order + self.counts['failed'])

    def figures(self) -> dict[str, int | float]:
        """Every count of this camera (what ``/diagnostics`` carries)."""
        core = {k: v for k, v in self.core.report()[self.camera].items() if k != 'gaps_s'}
        core['gap_frames'] = core.pop('dropped')
        processed = self.processed_frames()
        return {**self.counts, 'missing_in': self.stride.missing,
                'processed': processed, 'skipped': self.stride.skipped,
                'stride': self.stride.stride, 'most_stride': self.stride.most_stride,
                'dropped_behind': self.work.dropped,
                'waiting': self.work.waiting, 'most_waiting': self.work.most_waiting,
                'work_queue': self.work.maxsize, **self.latency.figures(), **core}

    def publish_diagnostics(self) -> None:
        """Counts of this camera as one DiagnosticStatus (WARN on any fault, a silent camera,
        or pairs off their epipolar lines: the cameras moved since the calibration)."""
        c = self.figures()
        faults = sum(int(c[k]) for k in ('missing_in', 'undecodable', 'failed', 'skipped',
                                         'dropped_behind', 'dropped_stale', 'gap_frames',
                                         'out_of_order'))
        message = (f"{c['frames_in']} frames in, {c['missing_in']} missing, "
                   f"{c['processed']} processed, "
                   f"{c['skipped']} skipped (stride {c['stride']}), "
                   f"{c['dropped_behind']} dropped behind, {c['detected']} detections, "
                   f"{c['lost']} lost, {faults} faults, shake up to "
                   f"{float(c['shake_max_px']):.1f} px ({c['shake_frames']} frames corrected, "
                   f"{c['shake_unknown']} not estimated)")
        silent = (time.monotonic() - self.last_arrival_s
                  if self.last_arrival_s is not None else 0.0)
        if silent > self.silent_s:
            message = f'no frame for {silent:.1f} s; ' + message
        drift = int(c.get('drift_frames', 0))
        if drift:
            message = (f"{drift} frames with pairs {float(c['pair_residual_px']):.1f} px "
                       'from their epipolar lines: cameras moved since the calibration? '
                       + message)
        status = DiagnosticStatus(
            level=DiagnosticStatus.WARN if faults or drift or silent > self.silent_s
            else DiagnosticStatus.OK,
            name=f'dempath_detector: {self.camera}', hardware_id=self.camera, message=message,
            values=[KeyValue(key=k, value=str(v)) for k, v in c.items()])
        self.pub_diag.publish(DiagnosticArray(header=_now_header(self), status=[status]))

    def destroy_node(self) -> None:
        """Stop the worker (frames still waiting are counted as dropped), then the node."""
        self.work.stop()
        super().destroy_node()


def _stamp_s(msg: Any) -> float:
    return float(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)


def _bgr(msg: Image) -> NDArray[np.uint8]:
    """A bgr8 or rgb8 Image as a contiguous BGR array; ValueError naming the fault."""
    if msg.encoding not in ('bgr8', 'rgb8'):
        raise ValueError(f'encoding {msg.encoding!r} (bgr8 or rgb8 expected)')
    if msg.step < 3 * msg.width or len(msg.data) != msg.step * msg.height:
        raise ValueError(f'{len(msg.data)} bytes do not fit {msg.width}x{msg.height}, '
                         f'step {msg.step}')
    rows = np.frombuffer(bytes(msg.data), np.uint8).reshape(msg.height, msg.step)
    img = rows[:, :msg.width * 3].reshape(msg.height, msg.width, 3)
    return np.ascontiguousarray(img[..., ::-1] if msg.encoding == 'rgb8' else img)


def _now_header(node: Node) -> Any:
    from std_msgs.msg import Header

    return Header(stamp=node.get_clock().now().to_msg())


def _grid(p: dict[str, Any]) -> MarkerGrid:
    """The marker grid of the ``scene`` parameter, else of the ``marker_*`` parameters."""
    if p['scene']:
        return MarkerGrid.from_scene(str(p['scene']))
    try:
        return MarkerGrid(rows=int(p['marker_rows']), columns=int(p['marker_columns']),
                          spacing_x_m=float(p['marker_spacing_x_m']),
                          spacing_z_m=float(p['marker_spacing_z_m']), side=int(p['marker_side']))
    except ValueError as err:
        raise ReconstructionError(f'marker grid parameters: {err}') from err


def _track_config(p: dict[str, Any]) -> StereoTrackConfig:
    """The tracker's settings of the node's parameters; ReconstructionError naming a bad one."""
    grid, detector = _grid(p), _detector(p)
    try:
        return StereoTrackConfig(grid=grid, shake=bool(p['correct_shake']), detector=detector,
                                 publish_gate=bool(p['publish_gate']),
                                 tool_speed_m_s=float(p['tool_speed_m_s']),
                                 whole_pass=bool(p['whole_pass']))
    except ValueError as err:
        raise ReconstructionError(str(err)) from err


def _detector(p: dict[str, Any]) -> DetectorConfig:
    """The detector's settings of the ``marker_bgr`` parameter; ReconstructionError naming it."""
    try:
        return DetectorConfig(marker_bgr=parse_bgr(str(p['marker_bgr'])))
    except ValueError as err:
        raise ReconstructionError(str(err)) from err


def _load_cameras(path: str) -> dict[str, Any]:
    """``{name: CameraModel}`` of a stereo YAML; ReconstructionError naming the file."""
    from dempath_calib.camera import StereoCalibration
    from dempath_calib.errors import CalibrationError

    if not path:
        raise ReconstructionError('calibration_file: required (a dempath_calib stereo YAML)')
    try:
        calib = StereoCalibration.load(path)
    except CalibrationError as err:
        raise ReconstructionError(f'{path!r}: {err}') from err
    return {c.name: c for c in calib.cameras}


def main(args: list[str] | None = None) -> int:
    """Console script ``dempath_detector``."""
    return run_node(DetectorNode, args)
