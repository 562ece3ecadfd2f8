"""ROS environment defaults that dempath applies before any rclpy context starts.

Discovery stays on loopback (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) unless the user has set
the variable, e.g. to ``SUBNET`` for a camera pair and a laptop on one network.
"""

from __future__ import annotations

import os

DISCOVERY_RANGE_VAR = 'ROS_AUTOMATIC_DISCOVERY_RANGE'
DEFAULT_DISCOVERY_RANGE = 'LOCALHOST'


def apply_ros_defaults() -> None:
    """Set dempath's ROS defaults in this process without overriding the user's choices."""
    os.environ.setdefault(DISCOVERY_RANGE_VAR, DEFAULT_DISCOVERY_RANGE)
    os.environ.setdefault('RCUTILS_COLORIZED_OUTPUT', '0')
