"""Message <-> numpy conversion for the simulation node (dempath_msgs, geometry and viz msgs)."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseStamped, Vector3, WrenchStamped
from numpy.typing import NDArray
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from dempath_msgs.msg import ParticleStates, RunEvent, ToolForce
from dempath_sim.runs import ROLE_MARKER, Frame

FRAME_ID = 'scene'  # the paper's frame: X lateral, Y up, Z travel (under REP 103's world)
TOOL_FRAME = 'tool'  # the tool's frame (dempath.frames): at its pose, axes of the scene
# sensor_msgs/PointCloud2 of the streamed particles: x, y, z, radius [m] and marker id
CLOUD_DTYPE = np.dtype([('x', '<f4'), ('y', '<f4'), ('z', '<f4'), ('radius', '<f4'),
                        ('marker_id', '<i4')])
CLOUD_FIELDS = (('x', 0, PointField.FLOAT32), ('y', 4, PointField.FLOAT32),
                ('z', 8, PointField.FLOAT32), ('radius', 12, PointField.FLOAT32),
                ('marker_id', 16, PointField.INT32))


def header(stamp: Time, frame_id: str = FRAME_ID) -> Header:
    """A header in the scene frame (or ``frame_id``)."""
    return Header(stamp=stamp, frame_id=frame_id)


def pose_of(position: NDArray[np.float64]) -> Pose:
    """A pose at ``position`` (3,) [m] with identity orientation (the tool does not turn)."""
    pose = Pose()
    pose.position = Point(x=float(position[0]), y=float(position[1]), z=float(position[2]))
    pose.orientation.w = 1.0
    return pose


def particle_states(frame: Frame, run_id: str, stamp: Time) -> ParticleStates:
    """ParticleStates of the tracked particles of one frame (NaN rows for removed ones)."""
    return ParticleStates(
        header=header(stamp), run_id=run_id, sim_time=float(frame.t),
        ids=frame.ids.astype(np.uint32).tolist(), roles=frame.roles.astype(np.uint8).tolist(),
        marker_ids=frame.marker_ids.astype(np.int32).tolist(),
        positions=frame.positions.ravel().tolist(), velocities=frame.velocities.ravel().tolist(),
        radii=frame.radii.tolist(), tool_pose=pose_of(frame.tool_position))


def states_to_arrays(msg: ParticleStates) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Ids (n,) and positions (n, 3) [m] of a ParticleStates message."""
    return (np.asarray(msg.ids, dtype=np.int64),
            np.asarray(msg.positions, dtype=np.float64).reshape(-1, 3))


def tool_force(frame: Frame, run_id: str, stamp: Time) -> ToolForce:
    """ToolForce: wrench on the tool, draft force -F_z [N] and tool speed along +Z [m/s]."""
    msg = ToolForce(header=header(stamp), run_id=run_id, sim_time=float(frame.t))
    f, m = frame.tool_force, frame.tool_torque
    msg.wrench.force = Vector3(x=float(f[0]), y=float(f[1]), z=float(f[2]))
    msg.wrench.torque = Vector3(x=float(m[0]), y=float(m[1]), z=float(m[2]))
    msg.draft_force = float(-f[2])
    msg.tool_speed = float(frame.tool_velocity[2])
    return msg


def tool_wrench(frame: Frame, stamp: Time) -> WrenchStamped:
    """The force [N] and torque [N m] on the tool as the standard WrenchStamped, in the tool
    frame (the scene's axes at the tool: the same components as ToolForce's wrench)."""
    msg = WrenchStamped(header=header(stamp, TOOL_FRAME))
    f, m = frame.tool_force, frame.tool_torque
    msg.wrench.force = Vector3(x=float(f[0]), y=float(f[1]), z=float(f[2]))
    msg.wrench.torque = Vector3(x=float(m[0]), y=float(m[1]), z=float(m[2]))
    return msg


def particle_cloud(frame: Frame, stamp: Time) -> PointCloud2:
    """The streamed particles (markers and candidates) as a PointCloud2 with their radii.

    Fields ``x, y, z, radius`` (float32, m) and ``marker_id`` (int32, 0: not a marker);
    removed particles (NaN) are left out.
    """
    keep = np.isfinite(frame.positions).all(axis=1)
    points = np.zeros(int(keep.sum()), CLOUD_DTYPE)
    for k, axis in enumerate('xyz'):
        points[axis] = frame.positions[keep, k]
    points['radius'] = frame.radii[keep]
    points['marker_id'] = frame.marker_ids[keep]
    return PointCloud2(
        header=header(stamp), height=1, width=len(points), is_bigendian=False,
        point_step=CLOUD_DTYPE.itemsize, row_step=CLOUD_DTYPE.itemsize * len(points),
        is_dense=True, data=points.tobytes(),
        fields=[PointField(name=n, offset=o, datatype=d, count=1) for n, o, d in CLOUD_FIELDS])


def tool_pose(frame: Frame, stamp: Time) -> PoseStamped:
    """The tool reference point (tip) as a PoseStamped."""
    return PoseStamped(header=header(stamp), pose=pose_of(frame.tool_position))


def run_event(run_id: str, event: int, detail: str, stamp: Time) -> RunEvent:
    """A RunEvent (RunEvent.STARTED / FINISHED / ABORTED)."""
    return RunEvent(header=header(stamp), run_id=run_id, event=event, detail=detail)


def _points(xyz: NDArray[np.float64]) -> list[Point]:
    finite = xyz[np.isfinite(xyz).all(axis=1)]
    return [Point(x=float(p[0]), y=float(p[1]), z=float(p[2])) for p in finite]


def marker_array(frame: Frame, tool_triangles: NDArray[np.float64], stamp: Time) -> MarkerArray:
    """Markers (red spheres), candidates (grey) and the tool mesh (triangle list) for Foxglove."""
    is_marker = frame.roles == ROLE_MARKER
    out = MarkerArray()
    for ident, (mask, rgba) in enumerate(((is_marker, (0.9, 0.1, 0.1, 1.0)),
                                          (~is_marker, (0.6, 0.6, 0.6, 0.6)))):
        m = Marker(header=header(stamp), ns='dempath_sim', id=ident, type=Marker.SPHERE_LIST,
                   action=Marker.ADD)
        d = 2.0 * float(np.nanmean(frame.radii)) if len(frame.radii) else 0.01
        m.scale = Vector3(x=d, y=d, z=d)
        m.color = ColorRGBA(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])
        m.pose.orientation.w = 1.0
        m.points = _points(frame.positions[mask])
        out.markers.append(m)
    tool = Marker(header=header(stamp), ns='dempath_sim', id=2, type=Marker.TRIANGLE_LIST,
                  action=Marker.ADD)
    tool.scale = Vector3(x=1.0, y=1.0, z=1.0)
    tool.color = ColorRGBA(r=0.3, g=0.35, b=0.45, a=1.0)
    tool.pose = pose_of(frame.tool_position)
    tool.points = _points(tool_triangles.reshape(-1, 3))
    out.markers.append(tool)
    return out
