"""Tests of the live pass gate, the camera watch and the counting work queue."""

from __future__ import annotations

import threading

import pytest

from dempath.workqueue import WorkQueue
from dempath_recon.livepass import CameraWatch, PassConfig, PassGate


def test_tool_motion_starts_and_ends_a_pass_with_hysteresis() -> None:
    """A jolt does not start a pass; sustained speed does; a stop ends it; abort waits a stop."""
    gate = PassGate(PassConfig(start_speed=0.3, stop_speed=0.1, hold_s=0.2))
    z, changes = 0.0, []
    speeds = [0.0] * 10 + [1.0] * 2 + [0.0] * 10 + [1.0] * 30 + [0.0] * 30
    for k, v in enumerate(speeds):
        z += v * 0.02
        change = gate.on_tool(k * 0.02, z)
        if change:
            changes.append((change.pass_id, change.started, round(change.stamp_s, 2)))
    assert changes == [(1, True, 0.62), (1, False, 1.24)]  # 0.2 s after each crossing
    gate.on_tool(2.0, z)
    gate.on_tool(2.02, z + 0.03)
    gate.on_tool(2.3, z + 0.5)
    assert gate.active
    gate.abort()
    assert gate.on_tool(2.6, z + 1.0) is None and gate.on_tool(3.0, z + 2.0) is None
    assert not gate.active


def test_run_events_start_and_end_passes() -> None:
    """With the run_event trigger, STARTED and FINISHED delimit passes; motion is ignored."""
    gate = PassGate(PassConfig(trigger='run_event'))
    assert gate.on_tool(0.0, 0.0) is None and gate.on_tool(1.0, 5.0) is None
    start = gate.on_event(True, 1.0)
    assert start is not None and start.pass_id == 1 and gate.on_event(True, 1.1) is None
    end = gate.on_event(False, 2.0, 'stop button')
    assert end is not None and end.detail == 'stop button' and not gate.active
    with pytest.raises(ValueError, match='stop_speed: out of range'):
        PassConfig(start_speed=0.2, stop_speed=0.3)


def test_camera_watch_names_the_stopped_camera() -> None:
    """A camera silent for longer than the timeout is named; one never seen counts from start."""
    watch = CameraWatch(('cam_side', 'cam_front'), 0.5)
    watch.seen('cam_side', 10.0)
    assert watch.stopped(10.4, since_s=10.0) == []
    watch.seen('cam_side', 10.5)
    assert watch.stopped(10.6, since_s=10.0) == ['cam_front']


def test_work_queue_counts_what_it_drops() -> None:
    """A blocked worker: the queue keeps maxsize items, drops and counts the oldest."""
    release = threading.Event()
    handled: list[int] = []
    queue: WorkQueue[int] = WorkQueue(lambda i: (release.wait(5), handled.append(i)), 3)
    for i in range(8):
        queue.put(i)
    release.set()
    deadline = threading.Event()
    while queue.waiting and not deadline.wait(0.01):
        pass
    assert queue.dropped + len(handled) == 8 and queue.most_waiting == 3
    assert handled[-3:] == [5, 6, 7]
    queue.stop()
