"""Diagnosis node: accumulates a measured pass and publishes a Diagnosis when the pass ends.

Subscribes to the measured MarkerPoints3D, the measured tool force (ToolForce on
``force_topic``), the simulator's ParticleStates (their run id names the case) and RunEvent on
the player's events; on FINISHED it diagnoses the pass against the scene's signature library
(built beforehand with ``dempath diagnose``; the node never simulates) on a worker thread and
publishes ``dempath_msgs/Diagnosis`` on ``/diagnosis``. Markers named in ``held_out`` are left
out of the diagnosis and their headline error is published apart (``held_out_*`` fields).
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from std_msgs.msg import Header

from dempath import topics
from dempath.errors import DempathError
from dempath.nodes.spin import run_node
from dempath_diagnose.decision.live import build_live, held_out_markers
from dempath_diagnose.headline.stage import headline_sentence, with_headline
from dempath_diagnose.nodes.convert import diagnosis_msg, force_sample, marker_frame
from dempath_msgs.msg import Diagnosis, MarkerPoints3D, ParticleStates, RunEvent, ToolForce

PARAMETERS = (
    ('scene', 'builtin:tiny', 'scene file or shipped scene of the model'),
    ('library', '', 'folder of the built signature library'),
    ('windows', 4, 'time windows of the statistics'),
    ('noise_m', 0.0015, 'measurement noise per axis [m]'),
    ('discrepancy_m', 0.002, 'model-discrepancy allowance on marker statistics [m]'),
    ('held_out', '', 'markers left out of the diagnosis and scored apart, e.g. 3,8,13'),
    ('force_topic', '/markers/tool_force', 'measured ToolForce topic'),
    ('events_topic', topics.PLAYER_EVENTS, 'RunEvent topic that ends a measured pass'),
    ('frame_id', 'world', 'frame of the published header'),
)


class DiagnoserNode(Node):
    """Diagnoses each measured pass when it ends."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_diagnoser', **kwargs)
        self.declare_parameters('', [(n, d, ParameterDescriptor(description=t))
                                     for n, d, t in PARAMETERS])
        v = {n: self.get_parameter(n).value for n, _, _ in PARAMETERS}
        self.frame_id = str(v['frame_id'])
        self.core = build_live(str(v['scene']), Path(str(v['library'])), int(v['windows']),
                               float(v['noise_m']), float(v['discrepancy_m']),
                               held_out_markers(str(v['held_out'])))
        self.case_id = ''
        self.lock = threading.Lock()
        self.pub = self.create_publisher(Diagnosis, topics.DIAGNOSIS, 10)
        self.create_subscription(MarkerPoints3D, topics.MARKER_POINTS, self.on_markers, 100)
        self.create_subscription(ToolForce, str(v['force_topic']), self.on_force, 100)
        self.create_subscription(ParticleStates, topics.SIM_STATES, self.on_states, 10)
        self.create_subscription(RunEvent, str(v['events_topic']), self.on_event, 10)

    def on_markers(self, msg: MarkerPoints3D) -> None:
        """Add one measured frame."""
        with self.lock:
            self.core.add_markers(*marker_frame(msg))

    def on_force(self, msg: ToolForce) -> None:
        """Add one measured force sample."""
        with self.lock:
            self.core.add_force(*force_sample(msg))

    def on_states(self, msg: ParticleStates) -> None:
        """The simulated run in progress names the case."""
        self.case_id = msg.run_id

    def on_event(self, msg: RunEvent) -> None:
        """Diagnose the pass on a worker thread when it has finished."""
        if msg.event != RunEvent.FINISHED:
            return
        threading.Thread(target=self.publish_diagnosis, args=(msg.run_id,), daemon=True).start()

    def publish_diagnosis(self, run_id: str) -> None:
        """Diagnose what was received and publish it (one error line if it cannot be)."""
        try:
            with self.lock:
                result = self.core.finish()
            core = self.core
            result = with_headline(result, core.library, core.geometry.cube_m,
                                   core.allowance.noise_m)
        except DempathError as err:
            self.get_logger().error(f'cannot diagnose pass {run_id!r}: {err}')  # type: ignore[no-untyped-call]
            return
        header = Header(frame_id=self.frame_id, stamp=self.get_clock().now().to_msg())
        self.pub.publish(diagnosis_msg(result, run_id or self.case_id, header))
        self.get_logger().info(f'pass {run_id!r}: {result.decision.verdict}')  # type: ignore[no-untyped-call]
        if result.held_out is not None and 'value_mm' in result.held_headline:
            held = ', '.join(map(str, result.held_out.markers))
            line = headline_sentence(result.held_headline, f'of the held-out markers {held}')
            self.get_logger().info(line)  # type: ignore[no-untyped-call]


def main(args: list[str] | None = None) -> int:
    """Console script ``dempath_diagnoser``."""
    return int(run_node(DiagnoserNode, args))
