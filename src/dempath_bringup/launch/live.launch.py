"""``ros2 launch dempath_bringup live.launch.py``: the live rig's graph (docs/ros.md).

Nodes: ``GRAPHS['live']`` of :mod:`dempath_bringup.launchgraph`; parameters:
``config/live.yaml`` (installed to share/dempath_bringup/config); each launch argument
(``name:=value``, listed by ``--show-args``) overrides the parameter it names.
"""

from __future__ import annotations

from typing import Any

from dempath_bringup.nodes.launch_description import graph_launch_description

GRAPH = 'live'


def generate_launch_description() -> Any:
    """The graph's launch description (dempath_bringup.nodes.launch_description)."""
    return graph_launch_description(GRAPH)
