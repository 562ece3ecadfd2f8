"""Every node's console script starts, spins and stops cleanly on SIGINT (the Jazzy main form)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dempath.nodes.harness import unique_domain_id

BIN = Path(sys.executable).parent
SCRIPTS = ['dempath_comparer', 'dempath_calibrator', 'dempath_recorder']


@pytest.mark.parametrize('script', SCRIPTS)
def test_script_starts_and_stops_on_sigint(script: str, tmp_path: Path) -> None:
    """The node comes up, and Ctrl-C ends it with status 0 and no traceback."""
    env = {**os.environ, 'ROS_DOMAIN_ID': str(unique_domain_id())}
    args = [str(BIN / script), '--ros-args', '-p', f'output:={tmp_path / "bag"}'] \
        if script == 'dempath_recorder' else [str(BIN / script)]
    proc = subprocess.Popen(args, cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    time.sleep(4.0)
    assert proc.poll() is None, f'{script} exited early: {proc.communicate()}'
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, f'{script}: status {proc.returncode}\n{err}'
    assert 'Traceback' not in err, err
