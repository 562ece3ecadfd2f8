"""``ros2 launch dempath_bringup live.launch.py``: the live rig's graph (docs/ros.md).

The nodes are ``GRAPHS['live']`` of :mod:`dempath_bringup.launchgraph`, their parameters
``config/live.yaml`` (installed to share/dempath_bringup/config), and each launch argument
(``name:=value``, see ``ros2 launch dempath_bringup live.launch.py --show-args``)
overrides the parameter it names.
"""

from __future__ import annotations

from pathlib import Path

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from dempath_bringup.launchgraph import ARGUMENTS, GRAPHS

GRAPH = 'live'


def generate_launch_description() -> LaunchDescription:
    """Launch arguments, then one Node action per node of the graph."""
    config = Path(get_package_share_directory('dempath_bringup')) / 'config' / f'{GRAPH}.yaml'
    actions = [DeclareLaunchArgument(a.name, default_value=a.default, description=a.description)
               for a in ARGUMENTS[GRAPH]]
    for spec in GRAPHS[GRAPH]:
        overrides = {param: LaunchConfiguration(arg) for param, arg in spec.arguments}
        actions.append(Node(package=spec.package, executable=spec.executable,
                            namespace=spec.namespace or None, output='screen',
                            parameters=[str(config), overrides]))
    return LaunchDescription(actions)
