"""The ROS way in: ``colcon build``, then run a node from ``install/<pkg>/lib/<pkg>/``.

What ``ros2 run dempath_recon dempath_detector`` does after ``colcon build`` and
``source install/setup.bash``: find the executable in ``install/dempath_recon/lib/dempath_recon``
(where the package's ``setup.cfg`` puts console scripts) and run it with the install's Python
path first. ros2cli itself is not on the package index, so the test does those two steps by hand
(docs/ros.md). About 15 s for the build and 5 s for the node.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dempath.nodes.harness import RosHarness
from dempath_twin.rig import paper_rig

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = 'dempath_recon'
NODE = 'dempath_detector'
COLCON = Path(sys.executable).with_name('colcon')


def _site_packages(install: Path) -> Path:
    py = f'python{sys.version_info.major}.{sys.version_info.minor}'
    return install / PACKAGE / 'lib' / py / 'site-packages'


@pytest.fixture(scope='module')
def install(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``colcon build`` of dempath_recon and dempath_bringup into a temporary workspace."""
    if not COLCON.is_file():
        pytest.skip(f'{COLCON}: colcon not installed (requirements-dev.txt)')
    ws = tmp_path_factory.mktemp('ws')
    for pkg in (PACKAGE, 'dempath_bringup'):
        shutil.copytree(ROOT / 'src' / pkg, ws / 'src' / pkg,
                        ignore=shutil.ignore_patterns('__pycache__', '*.egg-info', 'build'))
    done = subprocess.run(
        [str(COLCON), '--log-base', str(ws / 'log'), 'build', '--base-paths', str(ws / 'src'),
         '--build-base', str(ws / 'build'), '--install-base', str(ws / 'install'),
         '--packages-select', PACKAGE, 'dempath_bringup'],
        cwd=ws, capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    return ws / 'install'


def test_colcon_puts_node_scripts_where_ros2_run_looks(install: Path) -> None:
    """Every console script of the package lands in install/<pkg>/lib/<pkg>/, none in bin/."""
    scripts = {p.name for p in (install / PACKAGE / 'lib' / PACKAGE).iterdir()}
    assert {'dempath_detector', 'dempath_reconstructor', 'dempath_clicker',
            'dempath_pass'} <= scripts, scripts
    assert not (install / PACKAGE / 'bin').exists()
    assert (install / PACKAGE / 'share' / PACKAGE / 'package.xml').is_file()
    index = install / PACKAGE / 'share' / 'ament_index' / 'resource_index' / 'packages' / PACKAGE
    assert index.is_file()


def test_colcon_installs_the_launch_and_parameter_files(install: Path) -> None:
    """``ros2 launch dempath_bringup field_replay.launch.py`` finds the file in share/, and the
    launch file finds its parameter file there."""
    share = install / 'dempath_bringup' / 'share' / 'dempath_bringup'
    assert sorted(p.name for p in (share / 'launch').iterdir()) == [
        'field_replay.launch.py', 'live.launch.py']
    assert sorted(p.name for p in (share / 'config').iterdir()) == ['field_replay.yaml',
                                                                    'live.yaml']


def test_installed_node_runs_from_the_install(install: Path, tmp_path: Path) -> None:
    """The detector script from install/ imports the installed package, joins the graph with its
    publisher and stops cleanly on Ctrl-C (exit status 0)."""
    env = dict(os.environ)
    env['PYTHONPATH'] = os.pathsep.join(filter(None, [str(_site_packages(install)),
                                                      env.get('PYTHONPATH', '')]))
    env['AMENT_PREFIX_PATH'] = os.pathsep.join([str(install / PACKAGE),
                                                env.get('AMENT_PREFIX_PATH', sys.prefix)])
    where = subprocess.run([sys.executable, '-c', f'import {PACKAGE}; print({PACKAGE}.__file__)'],
                           env=env, capture_output=True, text=True, check=True).stdout
    assert Path(where.strip()).is_relative_to(install), where
    calib = paper_rig().save(tmp_path / 'calib.yaml')
    script = install / PACKAGE / 'lib' / PACKAGE / NODE
    with RosHarness() as harness:
        env['ROS_DOMAIN_ID'] = str(harness.domain_id)
        name = f'{NODE}_{os.getpid()}_{time.monotonic_ns()}'  # no other test's node has it
        proc = subprocess.Popen(
            [str(script), '--ros-args', '-r', f'__node:={name}', '-p', 'camera:=cam_side',
             '-p', f'calibration_file:={calib}'], env=env, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True)
        try:
            def joined() -> bool:
                names = harness.probe.get_node_names()
                return name in names and any(
                    t == '/cam_side/pixel_points' for t, _ in
                    harness.probe.get_publisher_names_and_types_by_node(name, '/'))

            assert harness.spin_until(joined, timeout_s=30.0), 'the node never joined the graph'
        finally:
            time.sleep(0.2)
            proc.send_signal(signal.SIGINT)
            out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 0, out
