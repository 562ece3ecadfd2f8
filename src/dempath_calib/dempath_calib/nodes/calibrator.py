"""The calibration node: collects board views from both cameras, solves, publishes CameraInfo.

Subscribes to ``/cam_side`` and ``/cam_front`` image topics (compressed or raw), detects the
board on a worker thread, logs the progress every few seconds, solves on the ``~/solve``
Trigger service (or once the input has been idle for ``solve_after_idle_s``), publishes
``sensor_msgs/CameraInfo`` for both cameras with transient-local durability and writes the
calibration files into ``output_dir``.
"""

from __future__ import annotations

import time
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from std_srvs.srv import Trigger

from dempath import topics
from dempath.errors import DempathError
from dempath.nodes.spin import run_node
from dempath_calib.calibrator import CalibrationResult, Calibrator
from dempath_calib.collect import CollectorConfig, ViewCollector
from dempath_calib.nodes.convert import camera_info_msg, image_to_grey
from dempath_calib.outputs import save_result

PARAMETERS = [
    ('board', 'paper', 'board preset: paper (7x5, 40.4 mm, DICT_5X5_100) or caliscope'),
    ('square_m', 0.0, 'square side overriding the preset [m] (0 = preset)'),
    ('distortion', 'k1k2p1p2k3', 'distortion model: none, k1, k1k2, k1k2k3, k1k2p1p2, k1k2p1p2k3'),
    ('world', 'surface', 'world frame: surface (board on the sand first) or side (camera)'),
    ('min_views', 8, 'least usable views per camera'),
    ('offset_s', 0.0, 'front clock offset added to its stamps [s] (NaN = estimate)'),
    ('image_width', 1920, 'image width [px]'),
    ('image_height', 1080, 'image height [px]'),
    ('output_dir', '', 'folder for the calibration files ("" = none)'),
    ('solve_after_idle_s', 0.0, 'solve when no image came for this long [s] (0 = service only)'),
    ('compressed', True, 'subscribe to image_raw/compressed (else image_raw)'),
]
PROGRESS_PERIOD_S = 2.0  # period of the progress log line [s]


class CalibratorNode(Node):
    """Two-camera calibration node (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_calibrator', **kwargs)
        self.declare_parameters('', [(n, v, ParameterDescriptor(description=d))
                                     for n, v, d in PARAMETERS])
        self.config = CollectorConfig.from_params(
            {n: self.get_parameter(n).value for n, _, _ in PARAMETERS})
        self.collector = ViewCollector(Calibrator(self.config.calibration))
        self.result: CalibrationResult | None = None
        self._error = ''
        self._last_image = 0.0
        self._idle_tried = 0.0
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        self.info_pubs = [self.create_publisher(CameraInfo, topics.camera_topic(
            topics.CAMERA_INFO, cam), latched) for cam in topics.CAMERAS]
        template, kind = ((topics.IMAGE_COMPRESSED, CompressedImage) if self.config.compressed
                          else (topics.IMAGE_RAW, Image))
        for index, cam in enumerate(topics.CAMERAS):
            topic = topics.camera_topic(template, cam)
            self.create_subscription(kind, topic, self._image_callback(index, topic), 10)
        self.create_service(Trigger, '~/solve', self._on_solve)
        self.create_timer(PROGRESS_PERIOD_S, self._on_timer)

    def _image_callback(self, camera: int, topic: str) -> Any:
        def callback(msg: Any) -> None:
            try:
                stamp, grey = image_to_grey(msg, topic)
            except DempathError as err:
                self.get_logger().error(str(err))
                return
            self._last_image = time.monotonic()
            self.collector.put(camera, stamp, grey)
        return callback

    def _on_timer(self) -> None:
        if self._last_image == 0.0 or self.result is not None:
            return
        self.get_logger().info(f'{self.collector.calibrator.progress().line()}; dropped '
                               f'{self.collector.dropped[0]}+{self.collector.dropped[1]}')
        idle = self.config.solve_after_idle_s
        if idle > 0 and time.monotonic() - self._last_image > idle \
                and self._idle_tried != self._last_image:  # once per quiet spell
            self._idle_tried = self._last_image
            self.solve()

    def _on_solve(self, request: Trigger.Request, response: Trigger.Response) -> Any:
        response.success = self.solve()
        response.message = (f'RMSE side {self.result.report["rmse_px"]["side"]:.3f} px, front '
                            f'{self.result.report["rmse_px"]["front"]:.3f} px'
                            if self.result is not None else self._error)
        return response

    def solve(self) -> bool:
        """Drain the queue, calibrate, publish CameraInfo and write the files."""
        self._error = ''
        self.collector.drain()
        try:
            self.result = self.collector.calibrator.solve()
            if self.config.output_path is not None:
                save_result(self.result, self.config.output_path,
                            {'dropped_images': list(self.collector.dropped)})
        except DempathError as err:
            self._error = str(err)
            self.get_logger().error(self._error)
            return False
        for pub, cam in zip(self.info_pubs, self.result.calibration.cameras, strict=True):
            msg = camera_info_msg(cam, f'{cam.name}_optical')
            msg.header.stamp = self.get_clock().now().to_msg()
            pub.publish(msg)
        self.get_logger().info(f'calibrated: {self.result.report["rmse_px"]}')
        return True

    def destroy_node(self) -> None:
        """Stop the detection thread, then the node."""
        self.collector.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Run the node (console script ``dempath_calibrator``)."""
    return run_node(CalibratorNode, args)
