"""Message <-> numpy conversion for the reconstruction node (the only module knowing the types)."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from dempath_msgs.msg import MarkerPoints3D, PixelPoints
from dempath_recon.pairing import PixelFrame
from dempath_recon.stream import MarkerFrame3D

FIELD_FRAME = 'field'  # the measurement's frame (calibration world: the board on the sand)
MARKER_DIAMETER_M = 0.008  # the paper's clay markers, about 8 mm


def stamp_to_s(stamp: Time) -> float:
    """builtin_interfaces/Time -> seconds."""
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def s_to_stamp(t_s: float) -> Time:
    """Seconds -> builtin_interfaces/Time."""
    sec = int(np.floor(t_s))
    return Time(sec=sec, nanosec=min(round((t_s - sec) * 1e9), 999_999_999))


def pixel_points_to_frame(msg: PixelPoints, camera: int) -> PixelFrame:
    """dempath_msgs/PixelPoints -> PixelFrame of camera SIDE (0) or FRONT (1)."""
    uv = np.column_stack([np.asarray(msg.u, dtype=np.float64),
                          np.asarray(msg.v, dtype=np.float64)]) if len(msg.u) else np.zeros((0, 2))
    return PixelFrame(camera, stamp_to_s(msg.header.stamp), np.asarray(msg.marker_ids), uv)


def frame_to_marker_points(frame: MarkerFrame3D, method: str) -> MarkerPoints3D:
    """MarkerFrame3D -> dempath_msgs/MarkerPoints3D in the world frame."""
    msg = MarkerPoints3D()
    msg.header = Header(stamp=s_to_stamp(frame.stamp_s), frame_id=FIELD_FRAME)
    msg.method = method
    msg.marker_ids = [int(i) for i in frame.ids]
    msg.x, msg.y, msg.z = (frame.xyz[:, k].tolist() for k in range(3))
    msg.sigma_x, msg.sigma_y, msg.sigma_z = (frame.sigma[:, k].tolist() for k in range(3))
    msg.reprojection_error = frame.reprojection_error.astype(np.float32).tolist()
    return msg


def frame_to_marker_array(frame: MarkerFrame3D) -> MarkerArray:
    """One sphere per marker (id = marker id) for Foxglove, sized by the 1-sigma ellipsoid."""
    out = MarkerArray()
    header = Header(stamp=s_to_stamp(frame.stamp_s), frame_id=FIELD_FRAME)
    for mid, p, s in zip(frame.ids, frame.xyz, frame.sigma, strict=True):
        m = Marker(header=header, ns='dempath_markers', id=int(mid), type=Marker.SPHERE,
                   action=Marker.ADD)
        m.pose.position = Point(x=float(p[0]), y=float(p[1]), z=float(p[2]))
        m.pose.orientation.w = 1.0
        m.scale.x, m.scale.y, m.scale.z = (max(MARKER_DIAMETER_M, 2.0 * float(v)) for v in s)
        m.color = ColorRGBA(r=1.0, g=0.4, b=0.0, a=0.8)
        out.markers.append(m)
    return out
