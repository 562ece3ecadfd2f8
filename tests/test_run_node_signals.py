"""A node's console script stops cleanly on a Ctrl-C that arrives while the node is being built.

``run_node`` holds SIGINT and SIGTERM while the node is built, but a thread that a library
started before that (OpenBLAS's pool, started when numpy is imported) still takes them, and
Python then raises KeyboardInterrupt in the main thread wherever it is: inside a finaliser
(``__del__``) Python prints "Exception ignored" and drops it, and the node went on spinning
after its Ctrl-C (seen once in 103 stress runs of ``dempath_comparer``: the process was still
spinning 60 s after the signal). The build below spends its time in finalisers, with such a
thread beside it, so the interrupt lands in one.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

from dempath.nodes.harness import RosHarness

SLOW_BUILD = """
import sys, threading, time
from rclpy.node import Node
from dempath.nodes.spin import run_node

class Finalised:
    def __del__(self):
        end = time.monotonic() + 0.002
        while time.monotonic() < end:  # Python work inside a finaliser
            pass

class SlowBuild(Node):
    def __init__(self):
        super().__init__('slow_build')
        print('building', flush=True)
        end = time.monotonic() + 2.0
        while time.monotonic() < end:
            Finalised()
        print('built', flush=True)

# a thread older than run_node's mask, like OpenBLAS's pool: the kernel gives it the signal
threading.Thread(target=time.sleep, args=(60,), daemon=True).start()
sys.exit(run_node(SlowBuild))
"""


def test_ctrl_c_during_the_build_stops_the_node(tmp_path: Path,
                                                ros_harness: RosHarness) -> None:
    """Ctrl-C while the node is built ends the process with status 0 once the build is done."""
    script = tmp_path / 'slow_build.py'
    script.write_text(SLOW_BUILD)
    env = {**os.environ, 'ROS_DOMAIN_ID': str(ros_harness.domain_id)}
    proc = subprocess.Popen([sys.executable, str(script)], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == 'building'
    proc.send_signal(signal.SIGINT)
    try:
        out, err = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        raise AssertionError(f'still running 30 s after Ctrl-C during the build\n{err}') from None
    assert proc.returncode == 0, err
    assert 'built' in out
    assert 'Traceback' not in err, err
