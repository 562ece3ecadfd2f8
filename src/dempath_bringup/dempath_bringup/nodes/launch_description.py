"""The ``LaunchDescription`` of a graph of :mod:`dempath_bringup.launchgraph` (launch files).

Launch arguments first (:data:`~dempath_bringup.launchgraph.ARGUMENTS`), then one ``launch_ros``
Node per node of the graph with the graph's parameter file (``share/dempath_bringup/config/
<graph>.yaml``) and, over it, the launch arguments' values for the parameters they name.
``launch``, ``launch_ros`` and ``ament_index_python`` come with a ROS install (they are not on
the package index): they are imported when a launch file asks, never by the rest of dempath.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dempath_bringup.launchgraph import ARGUMENTS, GRAPHS


def graph_launch_description(graph: str) -> Any:
    """The ``launch.LaunchDescription`` that starts ``GRAPHS[graph]``."""
    from ament_index_python.packages import get_package_share_directory
    from launch import LaunchDescription  # type: ignore[attr-defined]  # mypy sees launch/ here
    from launch.actions import DeclareLaunchArgument
    from launch.substitutions import LaunchConfiguration
    from launch_ros.actions import Node

    config = Path(get_package_share_directory('dempath_bringup')) / 'config' / f'{graph}.yaml'
    actions: list[Any] = [DeclareLaunchArgument(a.name, default_value=a.default,
                                                description=a.description)
                          for a in ARGUMENTS[graph]]
    for spec in GRAPHS[graph]:
        overrides = {param: LaunchConfiguration(arg) for param, arg in spec.arguments}
        actions.append(Node(package=spec.package, executable=spec.executable,
                            namespace=spec.namespace or None, output='screen',
                            parameters=[str(config), overrides]))
    return LaunchDescription(actions)
