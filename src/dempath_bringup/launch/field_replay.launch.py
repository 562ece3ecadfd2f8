"""``ros2 launch dempath_bringup field_replay.launch.py``: replay a field bag (docs/ros.md).

Nodes: ``GRAPHS['field_replay']`` of :mod:`dempath_bringup.launchgraph`; parameters:
``config/field_replay.yaml`` (installed to share/dempath_bringup/config); each launch argument
(``name:=value``, listed by ``--show-args``) overrides the parameter it names.
"""

from __future__ import annotations

from typing import Any

from dempath_bringup.nodes.launch_description import graph_launch_description

GRAPH = 'field_replay'


def generate_launch_description() -> Any:
    """The graph's launch description (dempath_bringup.nodes.launch_description)."""
    return graph_launch_description(GRAPH)
