"""The simulation node, launch-free: the tiny scene runs and its states reach subscribers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from rclpy.qos import DurabilityPolicy, QoSProfile
from visualization_msgs.msg import MarkerArray

from dempath import topics
from dempath.nodes.harness import RosHarness
from dempath_msgs.msg import ParticleStates, RunEvent, ToolForce
from dempath_sim.nodes.convert import states_to_arrays
from dempath_sim.nodes.simulator import SimulatorNode
from dempath_sim.simconfig import SimulatorConfig

LATCHED = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def test_node_runs_tiny_scene(ros_harness: RosHarness,
                              tmp_path_factory: pytest.TempPathFactory) -> None:
    """Started, states of 15 markers plus candidates, force, pose, viz, then finished."""
    cache = str(Path(tmp_path_factory.getbasetemp()) / 'packings')
    states = ros_harness.collect(ParticleStates, topics.SIM_STATES, 50)
    forces = ros_harness.collect(ToolForce, topics.SIM_TOOL_FORCE, 50)
    poses = ros_harness.collect(PoseStamped, topics.SIM_TOOL_POSE, 50)
    viz = ros_harness.collect(MarkerArray, topics.SIM_VIZ, 5)
    events = ros_harness.collect(RunEvent, topics.SIM_RUN_EVENTS, LATCHED)
    ros_harness.start(SimulatorNode, scene='tiny', cache_dir=cache, viz_every=5)
    done = ros_harness.spin_until(
        lambda: any(e.event == RunEvent.FINISHED for e in events), timeout_s=240.0)
    assert done, f'no FINISHED event; got {[(e.event, e.detail) for e in events]}'
    ros_harness.spin_for(0.3)
    assert events[0].event == RunEvent.STARTED and events[0].run_id.startswith('tiny-s1-')
    assert len(states) > 10 and len(forces) > 10 and len(poses) > 10 and viz
    last = states[-1]
    ids, positions = states_to_arrays(last)
    assert list(last.marker_ids[:15]) == list(range(1, 16)) and len(ids) > 15
    assert positions.shape == (len(ids), 3) and last.run_id == events[0].run_id
    assert np.isfinite(positions[:15]).all()
    assert last.tool_pose.position.z == pytest.approx(poses[-1].pose.position.z)
    assert forces[-1].draft_force == pytest.approx(-forces[-1].wrench.force.z)
    assert len(viz[-1].markers) == 3


def test_node_reports_bad_scene(ros_harness: RosHarness) -> None:
    """A bad scene name ends the run with an ABORTED event naming it; the node keeps spinning."""
    events = ros_harness.collect(RunEvent, topics.SIM_RUN_EVENTS, LATCHED)
    ros_harness.start(SimulatorNode, scene='no_such_scene')
    assert ros_harness.spin_until(lambda: len(events) >= 1, timeout_s=20.0)
    assert events[0].event == RunEvent.ABORTED and 'no_such_scene' in events[0].detail


def test_config_validates() -> None:
    """SimulatorConfig refuses bad values with the field name."""
    with pytest.raises(ValueError, match='viz_every'):
        SimulatorConfig(viz_every=0)
    cfg = SimulatorConfig.from_params({'scene': 'tiny', 'effects': [''], 'off': ['cohesion']})
    assert cfg.effects == () and cfg.off == ('cohesion',)
