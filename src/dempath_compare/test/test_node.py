"""The compare node, launch-free: topics in, scores and markers out when a run ends."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from dempath import topics
from dempath_compare.nodes.comparer import ComparerNode
from dempath_msgs.msg import MarkerPoints3D, ParticleStates, RunEvent, TrajectoryScoreArray

OFFSETS = (0.0, 0.003, 0.006, 0.009)  # lateral offsets of the candidates [m]; 0 is the truth


def marker_path(marker: int, k: int) -> np.ndarray:
    """(k, 3) m: marker start on the grid, pushed 0.15 m along Z and lifted 30 mm."""
    s = np.linspace(0.0, 1.0, k)
    return np.stack([0.05 * marker + 0.01 * s * s, 0.03 * np.sin(np.pi * s),
                     0.15 * s], axis=1)


def measured_msgs(markers: tuple[int, ...]) -> list[MarkerPoints3D]:
    """20 camera frames (50 Hz) of the markers."""
    paths = {m: marker_path(m, 20) for m in markers}
    out = []
    for i in range(20):
        msg = MarkerPoints3D(method='dlt', marker_ids=list(markers))
        msg.header.stamp.sec, msg.header.stamp.nanosec = 0, int(i * 0.02 * 1e9)
        msg.x = [float(paths[m][i, 0]) for m in markers]
        msg.y = [float(paths[m][i, 1]) for m in markers]
        msg.z = [float(paths[m][i, 2]) for m in markers]
        out.append(msg)
    return out


def states_msgs(run_id: str, markers: tuple[int, ...]) -> list[ParticleStates]:
    """5 rest steps then 20 moving steps; per marker one exact candidate and three offset ones,
    plus one bed particle that the node must ignore."""
    ids = [100 * m + k for m in markers for k in range(len(OFFSETS))]
    owners = [m for m in markers for _ in OFFSETS]
    out = []
    for step in range(25):
        i = max(0, step - 5)
        pos = []
        for m in markers:
            for off in OFFSETS:
                p = marker_path(m, 20)[i] + ([off, 0.0, 0.0] if i > 0 else 0.0)
                pos += [float(v) for v in p]
        roles = [ParticleStates.ROLE_CANDIDATE] * len(ids) + [ParticleStates.ROLE_BED]
        out.append(ParticleStates(run_id=run_id, sim_time=0.02 * step, ids=[*ids, 9999],
                                  roles=roles, marker_ids=[*owners, 0],
                                  positions=[*pos, 0.0, -0.1, 0.0]))
    return out


def feed(ros_harness: Any, run_id: str, markers: tuple[int, ...]) -> None:
    """Publish the measured frames and one simulated run."""
    pm = ros_harness.publisher(MarkerPoints3D, topics.MARKER_POINTS)
    ps = ros_harness.publisher(ParticleStates, topics.SIM_STATES)
    assert ros_harness.wait_for_subscribers(pm) and ros_harness.wait_for_subscribers(ps)
    ros_harness.publish_all(pm, measured_msgs(markers))
    ros_harness.publish_all(ps, states_msgs(run_id, markers))


def test_node_scores_run_on_finished_event(ros_harness: Any) -> None:
    """After FINISHED the node publishes the exact candidate as rank 1 with MAE 0, per marker."""
    node = ros_harness.start(ComparerNode, top_n=3)
    scores = ros_harness.collect(TrajectoryScoreArray, topics.COMPARE_SCORES)
    viz = ros_harness.collect(MarkerArray, topics.COMPARE_VIZ)
    feed(ros_harness, 'run_a', (7, 9))
    assert ros_harness.spin_until(lambda: node.core.model.n_samples == 8 * 25, timeout_s=10)
    assert ros_harness.spin_until(lambda: node.core.measured.n_samples == 2 * 20, timeout_s=10)
    events = ros_harness.publisher(RunEvent, topics.SIM_RUN_EVENTS)
    assert ros_harness.wait_for_subscribers(events)
    events.publish(RunEvent(run_id='run_a', event=RunEvent.FINISHED))
    assert ros_harness.spin_until(lambda: scores and viz, timeout_s=20), 'no scores published'
    got = scores[0].scores
    assert len(got) == 6  # 2 markers x top 3
    for marker in (7, 9):
        mine = sorted([s for s in got if s.marker_id == marker], key=lambda s: s.rank)
        assert [s.model_particle_id for s in mine] == [100 * marker, 100 * marker + 1,
                                                       100 * marker + 2]
        assert mine[0].mae == pytest.approx(0.0, abs=1e-12) and mine[0].valid
        assert mine[1].mae == pytest.approx(0.003 * 19 / 20, rel=1e-6)
        assert mine[0].model_run_id == 'run_a'
    assert len(viz[0].markers) == 2 * (1 + 3)
    assert viz[0].markers[0].points[0].x == pytest.approx(0.35)


def test_node_trigger_service(ros_harness: Any) -> None:
    """The ~/score Trigger scores on request; with no data it answers success=False."""
    node = ros_harness.start(ComparerNode, top_n=2)
    client = ros_harness.probe.create_client(Trigger, '/dempath_comparer/score')
    assert ros_harness.spin_until(lambda: client.service_is_ready(), timeout_s=10)
    empty = client.call_async(Trigger.Request())
    assert ros_harness.spin_until(lambda: empty.done(), timeout_s=10)
    assert not empty.result().success and 'no measured' in empty.result().message
    scores = ros_harness.collect(TrajectoryScoreArray, topics.COMPARE_SCORES)
    feed(ros_harness, 'run_b', (3,))
    assert ros_harness.spin_until(lambda: node.core.model.n_samples == 4 * 25, timeout_s=10)
    assert ros_harness.spin_until(lambda: node.core.measured.n_samples == 20, timeout_s=10)
    future = client.call_async(Trigger.Request())
    assert ros_harness.spin_until(lambda: future.done() and bool(scores), timeout_s=20)
    assert future.result().success
    assert [s.model_particle_id for s in scores[0].scores] == [300, 301]
