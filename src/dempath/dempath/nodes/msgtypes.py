"""Message classes by type name, and QoS helpers shared by the player and the recorder."""

from __future__ import annotations

import importlib
from typing import Any

import yaml  # type: ignore[import-untyped]
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from dempath.errors import BagError


def import_message_class(msgtype: str) -> Any:
    """The rclpy class of ``pkg/msg/Name`` (from ``importlib.import_module('pkg.msg')``).

    Raises:
        BagError: The package or class cannot be imported (names the type and why).
    """
    parts = msgtype.split('/')
    if len(parts) != 3 or not all(parts):
        msg = f'{msgtype!r}: not a ROS 2 message type name (pkg/msg/Name)'
        raise BagError(msg)
    try:
        return getattr(importlib.import_module(f'{parts[0]}.{parts[1]}'), parts[2])
    except (ImportError, AttributeError) as err:
        msg = f'message type {msgtype} cannot be imported ({err})'
        raise BagError(msg) from err


def reliable_qos(depth: int, latched: bool = False) -> QoSProfile:
    """Reliable keep-last QoS of ``depth``; transient local when ``latched``."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def subscription_qos(node: Node, topic: str, depth: int) -> QoSProfile:
    """A QoS that matches every current publisher of ``topic`` and keeps latched messages.

    Best effort if any publisher is best effort; transient local if all of them are.
    """
    infos = node.get_publishers_info_by_topic(topic)
    best_effort = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in infos)
    latched = bool(infos) and all(
        i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos)
    qos = reliable_qos(depth, latched)
    if best_effort:
        qos.reliability = ReliabilityPolicy.BEST_EFFORT
    return qos


def _sec_nsec(duration: Duration) -> dict[str, int]:
    sec, nsec = divmod(duration.nanoseconds, 1_000_000_000)
    return {'sec': sec, 'nsec': nsec}


def offered_qos_yaml(node: Node, topic: str) -> str:
    """The QoS profiles offered by the publishers of ``topic`` as rosbag2 (format 9) YAML."""
    profiles = [{
        'history': q.history.name.lower(), 'depth': q.depth,
        'reliability': q.reliability.name.lower(), 'durability': q.durability.name.lower(),
        'deadline': _sec_nsec(q.deadline), 'lifespan': _sec_nsec(q.lifespan),
        'liveliness': q.liveliness.name.lower(),
        'liveliness_lease_duration': _sec_nsec(q.liveliness_lease_duration),
        'avoid_ros_namespace_conventions': q.avoid_ros_namespace_conventions,
    } for q in (info.qos_profile for info in node.get_publishers_info_by_topic(topic))]
    return str(yaml.safe_dump(profiles)) if profiles else ''
