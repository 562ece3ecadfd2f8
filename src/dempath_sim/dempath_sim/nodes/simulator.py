"""Simulation node: runs a scene in a worker thread and publishes what it records.

Publishes ParticleStates (markers and candidates), ToolForce, the tool PoseStamped, RunEvent
started / finished / aborted and a MarkerArray for Foxglove; logs sim time and the real-time
factor. Parameters: ``scene`` (file or shipped name), ``seed``, ``effects``
(EFFECT.PARAM=VALUE), ``off``, ``cache_dir``, ``candidates``, ``viz_every``.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from geometry_msgs.msg import PoseStamped, WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import PointCloud2
from visualization_msgs.msg import MarkerArray

from dempath import topics
from dempath.errors import DempathError
from dempath.nodes.spin import run_node
from dempath.nodes.subscribers import wait_for_subscribers
from dempath_msgs.msg import ParticleStates, RunEvent, ToolForce
from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.nodes import convert
from dempath_sim.runs import Frame, Progress, RunOptions, run_id, run_scene
from dempath_sim.simconfig import SimulatorConfig

LOG_PERIOD_S = 1.0  # wall time between progress log lines


class SimulatorNode(Node):
    """Loads the scene of its parameters and runs it once in a worker thread."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_simulator', **kwargs)
        d = SimulatorConfig()
        self.declare_parameters('', [
            ('scene', d.scene, ParameterDescriptor(description='scene file or shipped name')),
            ('seed', d.seed, ParameterDescriptor(description='packing seed, -1: the scene')),
            ('effects', [''], ParameterDescriptor(description='EFFECT.PARAM=VALUE overrides')),
            ('off', [''], ParameterDescriptor(description='effects switched off')),
            ('cache_dir', d.cache_dir, ParameterDescriptor(description='packing cache dir')),
            ('candidates', d.candidates, ParameterDescriptor(description='publish candidates')),
            ('viz_every', d.viz_every, ParameterDescriptor(description='frames per MarkerArray')),
            ('wait_for_subscribers', d.wait_for_subscribers, ParameterDescriptor(
                description='subscribers each data topic needs before the first frame')),
            ('wait_timeout_s', d.wait_timeout_s, ParameterDescriptor(
                description='longest wait for those subscribers [s]')),
        ])
        names = ('scene', 'seed', 'effects', 'off', 'cache_dir', 'candidates', 'viz_every',
                 'wait_for_subscribers', 'wait_timeout_s')
        self.config = SimulatorConfig.from_params(
            {n: self.get_parameter(n).value for n in names})
        latched = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.pub_states = self.create_publisher(ParticleStates, topics.SIM_STATES, 50)
        self.pub_force = self.create_publisher(ToolForce, topics.SIM_TOOL_FORCE, 50)
        self.pub_pose = self.create_publisher(PoseStamped, topics.SIM_TOOL_POSE, 50)
        self.pub_events = self.create_publisher(RunEvent, topics.SIM_RUN_EVENTS, latched)
        # keep 50 as the other topics: with 5 a recorder behind under load lost frames
        self.pub_viz = self.create_publisher(MarkerArray, topics.SIM_VIZ, 50)
        # the same in standard messages (docs/ros.md): the force, the particles with radii
        self.pub_wrench = self.create_publisher(WrenchStamped, topics.SIM_TOOL_WRENCH, 50)
        self.pub_cloud = self.create_publisher(PointCloud2, topics.SIM_CLOUD, 50)
        self.stop = threading.Event()
        self._run_id = self.config.scene
        self._frames = 0
        self._last_log = 0.0
        self.worker = threading.Thread(target=self.run, name='dempath_sim', daemon=True)
        self.worker.start()

    @property
    def run_id(self) -> str:
        """The run id of the run in progress (the scene's name until it is loaded)."""
        return self._run_id

    @property
    def frames_published(self) -> int:
        """ParticleStates frames published so far."""
        return self._frames

    def run(self) -> None:
        """Worker: load the scene, run it, publish events; package errors end the run."""
        rid = self.config.scene
        try:
            scene = self.config.load_scene()
            rid = run_id(scene)
            self._run_id = rid
            self.tool_triangles = TriangleMesh.from_stl(scene.tool.mesh,
                                                        scale=scene.tool.scale).triangles
            self._event(RunEvent.STARTED, f'scene {scene.name} seed {scene.seed}')
            wait_for_subscribers((self.pub_states, self.pub_force, self.pub_pose, self.pub_viz),
                                 self.config.wait_for_subscribers, self.config.wait_timeout_s,
                                 self.stop)
            result = run_scene(scene, RunOptions(self.config.cache_path, self._progress,
                                                 self._publish, self.stop))
        except DempathError as err:
            self.get_logger().error(f'run {rid} aborted: {err}')
            self._event(RunEvent.ABORTED, str(err), rid)
            return
        fill = result.meta['fill']
        self._event(RunEvent.FINISHED, f"{len(result.times)} frames, {result.meta['n_particles']}"
                                       f" particles, bulk density {fill['bulk_density_kg_m3']:.0f}"
                                       ' kg/m^3')

    def _event(self, event: int, detail: str, rid: str | None = None) -> None:
        stamp = self.get_clock().now().to_msg()
        self.pub_events.publish(convert.run_event(rid or self._run_id, event, detail, stamp))

    def _publish(self, frame: Frame) -> None:
        stamp = self.get_clock().now().to_msg()
        self.pub_states.publish(convert.particle_states(frame, self._run_id, stamp))
        self.pub_force.publish(convert.tool_force(frame, self._run_id, stamp))
        self.pub_pose.publish(convert.tool_pose(frame, stamp))
        if self._frames % self.config.viz_every == 0:
            self.pub_viz.publish(convert.marker_array(frame, self.tool_triangles, stamp))
            self.pub_cloud.publish(convert.particle_cloud(frame, stamp))
        self.pub_wrench.publish(convert.tool_wrench(frame, stamp))
        self._frames += 1

    def _progress(self, p: Progress) -> None:
        now = time.monotonic()
        if now - self._last_log >= LOG_PERIOD_S:
            self._last_log = now
            self.get_logger().info(f'{p.phase}: sim {p.sim_time_s:.3f}/{p.end_time_s:.3f} s, '
                                   f'real-time factor {p.real_time_factor:.3g}')

    def destroy_node(self) -> None:
        """Stop the worker at its next frame, then destroy the node."""
        self.stop.set()
        self.worker.join(timeout=30.0)
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Console script ``dempath_simulator``."""
    return run_node(SimulatorNode, args)
