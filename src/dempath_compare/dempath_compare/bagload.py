"""Trajectories from bags: MarkerPoints3D (measured) and ParticleStates (model) messages.

Reads with :mod:`dempath.bagio` (rosbags, dempath_msgs registered from their .msg text, no ROS
needed). Measured time is the message header stamp; model time is ``sim_time``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dempath.errors import BagError
from dempath_compare.accumulate import TrajectoryAccumulator
from dempath_compare.errors import InputError
from dempath_compare.records import MEASURED, Track

MARKER_TYPE = 'dempath_msgs/msg/MarkerPoints3D'
STATES_TYPE = 'dempath_msgs/msg/ParticleStates'
ROLE_BED = 2  # ParticleStates.ROLE_BED: background particles, never candidates


def load_bag(path: Path, kind: str, from_names: bool = False) -> list[Track]:
    """Tracks of ``kind`` from every topic of the matching type in a bag (``from_names``: tool
    speed and seed from the group names, :mod:`dempath_compare.runinfo`).

    Raises:
        InputError: the bag cannot be read or has no topic of the needed type.
    """
    from dempath.bagio import open_bag

    wanted = MARKER_TYPE if kind == MEASURED else STATES_TYPE
    try:
        with open_bag(path) as bag:
            topics = [t.name for t in bag.topics.values() if t.msgtype == wanted]
            if not topics:
                msg = f'{path}: no {wanted} topic in bag'
                raise InputError(msg)
            accumulator = TrajectoryAccumulator(from_names)
            for raw in bag.messages(topics):
                add_message(accumulator, bag.deserialize(raw), kind, path.stem)
    except BagError as err:
        raise InputError(str(err)) from err
    return accumulator.tracks(kind)


def add_message(accumulator: TrajectoryAccumulator, message: Any, kind: str, group: str) -> None:
    """Feed one deserialized MarkerPoints3D / ParticleStates (rosbags or rclpy object).

    Bed particles (role ROLE_BED) are skipped: only markers and their candidates are compared.
    """
    if kind == MEASURED:
        stamp = message.header.stamp
        t = float(stamp.sec) + 1e-9 * float(stamp.nanosec)
        xyz = np.stack([np.asarray(message.x), np.asarray(message.y), np.asarray(message.z)], 1)
        accumulator.add_markers(group, t, np.asarray(message.marker_ids, np.int64), xyz)
    else:
        ids = np.asarray(message.ids, np.int64)
        xyz = np.asarray(message.positions, np.float64).reshape(len(ids), 3)
        keep = np.asarray(message.roles, np.uint8) != ROLE_BED
        accumulator.add_particles(message.run_id or group, float(message.sim_time), ids[keep],
                                  np.asarray(message.marker_ids, np.int64)[keep], xyz[keep])

