"""Counts as diagnostic_msgs/DiagnosticArray on ``/diagnostics``, the ROS convention for health.

Measurement nodes never drop a frame silently: they count frames in, out and dropped, and publish
the counts here about once a second, where ``rqt_runtime_monitor``, Foxglove and the recorder
see them.
"""

from __future__ import annotations

from collections.abc import Mapping

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node


def counts_message(node: Node, name: str, counts: Mapping[str, float | int],
                   dropped_keys: tuple[str, ...] = ('dropped',)) -> DiagnosticArray:
    """One status named ``<node>: <name>``, WARN when any ``dropped_keys`` count is non-zero."""
    dropped = sum(int(counts.get(k, 0)) for k in dropped_keys)
    status = DiagnosticStatus(
        level=DiagnosticStatus.WARN if dropped else DiagnosticStatus.OK,
        name=f'{node.get_name()}: {name}', hardware_id=name,
        message=f'{dropped} dropped' if dropped else 'ok',
        values=[KeyValue(key=k, value=f'{v:g}' if isinstance(v, float) else str(v))
                for k, v in counts.items()])
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = node.get_clock().now().to_msg()
    return msg
