"""The recalibration's live progress, launch-free: published by the progress node while a
recalibration runs, recorded to MCAP by the recorder node, read back."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from dempath.bagio import open_bag
from dempath.nodes.recorder import RecorderNode
from dempath_diagnose.nodes.progress_publisher import TOPIC, RecalProgressNode, progress_publisher
from dempath_diagnose.recalibration.loop import recalibrate
from dempath_diagnose.recalibration.progress import Progress, State

from .test_recalibrate import SEEDS, evaluator, setup


def recorded(bag: Path) -> list[Any]:
    """The RecalibrationProgress messages of a bag, in order."""
    with open_bag(bag) as reader:
        return [reader.deserialize(m) for m in reader.messages([TOPIC])]


def test_progress_of_a_running_recalibration_is_recorded(ros_harness: Any,
                                                         tmp_path: Path) -> None:
    """Every iteration reaches the MCAP with its error, floor, parameter values and state."""
    recorder = ros_harness.start(RecorderNode, output=str(tmp_path / 'bag'), topics=[TOPIC])
    node = ros_harness.start(RecalProgressNode, run_id='synthetic')
    got: list[Progress] = []

    def publish(p: Progress) -> None:
        got.append(p)
        node.publish(p)
        ros_harness.executor.spin_once(timeout_sec=0.0)

    obj, ce = setup(0.8)
    r = recalibrate(obj, ce, evaluator(), budget=18, seeds_per_eval=SEEDS, progress=publish)
    assert ros_harness.spin_until(
        lambda: recorder.received_counts().get(TOPIC, 0) >= len(got), timeout_s=30), \
        f'recorded {recorder.received_counts()} of {len(got)}'
    recorder.finish()
    msgs = recorded(tmp_path / 'bag')
    assert [m.iteration for m in msgs] == [p.iteration for p in got]
    assert msgs[0].state == State.RUNNING and msgs[-1].state == State.FINISHED
    assert msgs[-1].detail == r.stop and msgs[-1].run_id == 'synthetic'
    assert all(m.floor == obj.floor.k for m in msgs)
    assert list(msgs[1].parameter_names) == ['cohesion.energy_density_j_m3']
    assert np.allclose(msgs[-1].best_error, r.after)
    assert [m.simulations for m in msgs[:-1]] == [s.simulations for s in r.steps]


def test_cli_publisher_reaches_a_recorder(ros_harness: Any, tmp_path: Path) -> None:
    """The publisher ``--publish-progress`` uses (own context) is seen by a recorder."""
    recorder = ros_harness.start(RecorderNode, output=str(tmp_path / 'bag'), topics=[TOPIC])
    records = [Progress('cohesion', i, e, min(10.0, e), 6, 12.6, ('cohesion.x',), (0.1 * i,),
                        3 * i, 9.0, State.RUNNING) for i, e in enumerate((40.0, 10.0))]
    records.append(Progress('cohesion', 2, math.inf, 10.0, 6, 12.6, ('cohesion.x',), (0.3,), 6,
                            0.0, State.INTERRUPTED, 'interrupted'))
    with progress_publisher('cli', domain_id=ros_harness.domain_id) as publish:
        for p in records:
            publish(p)
        assert ros_harness.spin_until(
            lambda: recorder.received_counts().get(TOPIC, 0) >= 3, timeout_s=30)
    recorder.finish()
    msgs = recorded(tmp_path / 'bag')
    assert [m.iteration for m in msgs] == [0, 1, 2]
    assert math.isinf(msgs[2].error) and msgs[2].state == State.INTERRUPTED
