"""Compare node: accumulates marker and particle trajectories, scores a run when it ends.

Subscribes to MarkerPoints3D (measured) and ParticleStates (model); when a RunEvent FINISHED
arrives (or the ``~/score`` Trigger service is called) it publishes a TrajectoryScoreArray with
the N best model trajectories per marker and a MarkerArray of them for Foxglove.
"""

from __future__ import annotations

from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from std_msgs.msg import Header
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from dempath import topics
from dempath.nodes.spin import run_node
from dempath_compare.config import CompareConfig
from dempath_compare.errors import CompareError
from dempath_compare.live import LiveComparer
from dempath_compare.nodes.convert import (
    best_markers_msg,
    marker_arrays,
    particle_arrays,
    scores_msg,
    stamp_seconds,
)
from dempath_compare.scoring import CompareResult
from dempath_msgs.msg import MarkerPoints3D, ParticleStates, RunEvent, TrajectoryScoreArray

PARAMETERS = (
    ('top_n', 10, 'N best model trajectories kept per marker'),
    ('sp', 3.0, 'start-of-motion sensitivity sp of v_thr = mean + sp * std'),
    ('rest_samples', 5, 'samples of the rest phase of a model trajectory'),
    ('z_weight', 1.0, 'Z weight w of d_i = sqrt(dx^2 + dy^2 + w dz^2)'),
    ('rank_by', 'sum', 'rank by S_sum (sum) or S_mean (mean)'),
    ('matching', 'dtw', 'nearest point among DTW-paired points (dtw) or all points (nearest)'),
    ('pairing', 'auto', 'auto, all, marker or cube'),
    ('identity_from_names', False, 'tool speed and seed from experiment and run names'),
    ('experiment', 'experiment', 'name of the measured experiment (group)'),
    ('frame_id', 'field', 'frame of the published MarkerArray (the measurement frame)'),
)
COMPARE_KEYS = ('top_n', 'sp', 'rest_samples', 'z_weight', 'rank_by', 'matching', 'pairing',
                'identity_from_names')


class ComparerNode(Node):
    """Scores model runs against the measured markers received so far."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_comparer', **kwargs)
        self.declare_parameters('', [(n, d, ParameterDescriptor(description=t))
                                     for n, d, t in PARAMETERS])
        values = {n: self.get_parameter(n).value for n, _, _ in PARAMETERS}
        self.frame_id = str(values['frame_id'])
        config = CompareConfig.from_params({k: values[k] for k in COMPARE_KEYS})
        self.core = LiveComparer(config, str(values['experiment']))
        self.scores_pub = self.create_publisher(TrajectoryScoreArray, topics.COMPARE_SCORES, 10)
        self.viz_pub = self.create_publisher(MarkerArray, topics.COMPARE_VIZ, 10)
        self.create_subscription(MarkerPoints3D, topics.MARKER_POINTS, self.on_markers, 100)
        self.create_subscription(ParticleStates, topics.SIM_STATES, self.on_states, 100)
        self.create_subscription(RunEvent, topics.SIM_RUN_EVENTS, self.on_event, 10)
        self.create_service(Trigger, '~/score', self.on_trigger)
        self._last_result: CompareResult | None = None

    @property
    def last_result(self) -> CompareResult | None:
        """The comparison behind the last published scores (None before the first)."""
        return self._last_result

    def on_markers(self, msg: MarkerPoints3D) -> None:
        """Add one measured time step."""
        self.core.add_markers(stamp_seconds(msg.header.stamp), *marker_arrays(msg))

    def on_states(self, msg: ParticleStates) -> None:
        """Add one model time step."""
        self.core.add_particles(msg.run_id, float(msg.sim_time), *particle_arrays(msg))

    def on_event(self, msg: RunEvent) -> None:
        """Score the run when it has finished."""
        if msg.event == RunEvent.FINISHED:
            try:
                self.publish_scores(msg.run_id or None)
            except CompareError as err:
                self.get_logger().error(f'cannot score run {msg.run_id!r}: {err}')  # type: ignore[no-untyped-call]

    def on_trigger(self, request: Trigger.Request, response: Trigger.Response) -> Any:
        """Score every run received so far."""
        try:
            count = self.publish_scores(None)
        except CompareError as err:
            response.success, response.message = False, str(err)
            return response
        response.success, response.message = True, f'published {count} scores'
        return response

    def publish_scores(self, run_id: str | None) -> int:
        """Score, publish scores and markers; returns the number of scores."""
        result = self.core.finish(run_id)
        self._last_result = result
        header = Header(frame_id=self.frame_id, stamp=self.get_clock().now().to_msg())
        scores = scores_msg(result, run_id or '', header)
        self.scores_pub.publish(scores)
        self.viz_pub.publish(best_markers_msg(result, header))
        self.get_logger().info(f'run {run_id or "all"}: published {len(scores.scores)} scores')  # type: ignore[no-untyped-call]
        return len(scores.scores)


def main(args: list[str] | None = None) -> int:
    """Console script ``dempath_comparer``."""
    return run_node(ComparerNode, args)
