"""Every node's console script starts, spins and stops cleanly on SIGINT (the Jazzy main form).

The test waits until the node is in the ROS graph (seen by the harness' probe in the same
domain) before it sends Ctrl-C, so a slow start on a loaded machine is not mistaken for a fault.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dempath.nodes.harness import RosHarness

BIN = Path(sys.executable).parent
SCRIPTS = ['dempath_comparer', 'dempath_calibrator', 'dempath_recorder']
START_TIMEOUT_S = 120.0  # imports (numpy, OpenCV, torch) can take long on a busy machine


@pytest.mark.parametrize('script', SCRIPTS)
def test_script_starts_and_stops_on_sigint(script: str, tmp_path: Path,
                                           ros_harness: RosHarness) -> None:
    """The node comes up, and Ctrl-C ends it with status 0 and no traceback."""
    # a crash in C (once: SIGSEGV on Ctrl-C in a fresh-clone CI) prints every thread's stack
    env = {**os.environ, 'ROS_DOMAIN_ID': str(ros_harness.domain_id), 'PYTHONFAULTHANDLER': '1'}
    # a name no other process has: another test's node of the same name in a domain that
    # happens to be the same (ids are drawn from 100) must not be taken for this one, which
    # would then get its Ctrl-C before its handler is in place (status -2, seen on a machine
    # running several suites at once)
    node_name = f'{script}_{os.getpid()}_{time.monotonic_ns()}'
    args = [str(BIN / script), '--ros-args', '-r', f'__node:={node_name}']
    if script == 'dempath_recorder':
        args += ['-p', f'output:={tmp_path / "bag"}']
    proc = subprocess.Popen(args, cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    up = ros_harness.spin_until(
        lambda: proc.poll() is not None or node_name in ros_harness.probe.get_node_names(),
        timeout_s=START_TIMEOUT_S)
    assert proc.poll() is None, f'{script} exited early: {proc.communicate()}'
    if not up:
        proc.kill()
        pytest.fail(f'{script}: node {node_name!r} not in the graph after {START_TIMEOUT_S} s')
    time.sleep(1.0)  # the node is in the graph before its main reaches the spin's try block
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, f'{script}: status {proc.returncode}\n{err}'
    assert 'Traceback' not in err, err
