"""Coordinate frames of a dempath recording, as ROS TF (``tf2_msgs/TFMessage``) without tf2.

The tree (docs/ros.md, "Frames")::

    world                    REP 103: X forward (= the tool's travel), Y left, Z up
    └── scene                the paper's frame: X lateral, Y up, Z travel (a rotation of world)
        ├── field            the measurement's frame: scene shifted to the marker grid centre
        │   ├── cam_side_optical    from the calibration (REP 103 optical: z forward, x right,
        │   └── cam_front_optical   y down; OpenCV's camera frame)
        └── tool             the tool's pose over time (``/tf``, from its PoseStamped)

Static transforms go to ``/tf_static`` once, the tool to ``/tf`` with its pose's stamp, so that
Foxglove and RViz place the cameras, markers, particles and the tool. This module is plain
Python: the transforms are records, serialised with a rosbags typestore (tf2_msgs is not on the
package index, so the recorder writes TF itself; docs/ros.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from dempath.errors import DempathError

FloatArray = NDArray[np.float64]
WORLD, SCENE, FIELD, TOOL = 'world', 'scene', 'field', 'tool'
TF_TYPE = 'tf2_msgs/msg/TFMessage'
TF, TF_STATIC = '/tf', '/tf_static'
# world <- scene: scene X (lateral) -> world Y, Y (up) -> world Z, Z (travel) -> world X
SCENE_IN_WORLD = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def optical_frame(camera: str) -> str:
    """The optical frame's name of ``camera`` (REP 103 suffix ``_optical``)."""
    return f'{camera}_optical'


@dataclass(frozen=True)
class Transform:
    """The pose of ``child`` in ``parent``: ``p_parent = rotation @ p_child + translation``.

    Attributes:
        parent: parent frame id.
        child: child frame id.
        translation: (3,) child origin in the parent frame [m].
        rotation: (3, 3) parent <- child rotation (proper: det +1).
    """

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[tuple[float, float, float], ...]

    def __post_init__(self) -> None:
        rot = np.asarray(self.rotation, dtype=np.float64)
        if rot.shape != (3, 3) or not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6) \
                or np.linalg.det(rot) < 0:
            msg = f'{self.parent} -> {self.child}: rotation is not a proper rotation: {rot}'
            raise ValueError(msg)

    @classmethod
    def of(cls, parent: str, child: str, translation: Any, rotation: Any = None) -> Transform:
        """From arrays: translation (3,) m, rotation (3, 3) parent <- child (identity if None)."""
        rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
        t = np.asarray(translation, dtype=np.float64).reshape(3)
        return cls(parent, child, (float(t[0]), float(t[1]), float(t[2])),
                   tuple(tuple(float(v) for v in row) for row in rot))  # type: ignore[misc]

    def matrix(self) -> FloatArray:
        """(4, 4) homogeneous parent <- child."""
        out = np.eye(4)
        out[:3, :3] = self.rotation
        out[:3, 3] = self.translation
        return out

    def quaternion(self) -> tuple[float, float, float, float]:
        """(x, y, z, w) unit quaternion of the rotation."""
        return quaternion_from_matrix(np.asarray(self.rotation))


def quaternion_from_matrix(rot: FloatArray) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a proper rotation matrix (3, 3), w >= 0.

    Shepperd's method (J. Guidance and Control 1(3), 1978): take the largest of the four
    squared components from the trace and the diagonal, the other three from the off-diagonal.
    """
    m = np.asarray(rot, dtype=np.float64)
    t = np.trace(m)
    cands = np.array([t, m[0, 0], m[1, 1], m[2, 2]])
    k = int(np.argmax(cands))
    if k == 0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    else:
        i, j, n = k - 1, k % 3, (k + 1) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[n, n])
        q = [0.0, 0.0, 0.0, (m[n, j] - m[j, n]) / s]
        q[i], q[j], q[n] = s / 4, (m[j, i] + m[i, j]) / s, (m[n, i] + m[i, n]) / s
    quat = np.asarray(q) / np.linalg.norm(q)
    quat = -quat if quat[3] < 0 else quat
    return float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3])


def matrix_from_quaternion(x: float, y: float, z: float, w: float) -> FloatArray:
    """(3, 3) rotation of a unit quaternion (x, y, z, w)."""
    n = np.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def camera_transform(camera: str, rot_world_to_cam: Any, t_world_to_cam: Any,
                     parent: str = FIELD) -> Transform:
    """``parent`` -> ``<camera>_optical`` from a calibration's extrinsics.

    Args:
        camera: camera name (``cam_side``).
        rot_world_to_cam: (3, 3) R of ``x_cam = R x_parent + t`` (OpenCV convention).
        t_world_to_cam: (3,) t of the same [m].
        parent: the calibration's world frame.
    """
    rot = np.asarray(rot_world_to_cam, dtype=np.float64)
    t = np.asarray(t_world_to_cam, dtype=np.float64).reshape(3)
    return Transform.of(parent, optical_frame(camera), -rot.T @ t, rot.T)


def scene_transforms(field_origin_in_scene: Any = (0.0, 0.0, 0.0)) -> list[Transform]:
    """world -> scene (the Y-up paper frame turned Z up) and scene -> field (a shift)."""
    return [Transform.of(WORLD, SCENE, np.zeros(3), SCENE_IN_WORLD),
            Transform.of(SCENE, FIELD, field_origin_in_scene)]


def save_frames(path: str | Path, transforms: list[Transform]) -> Path:
    """Write static transforms as YAML (what the recorder's ``frames_file`` reads)."""
    rows = [{'parent': t.parent, 'child': t.child, 'translation': list(t.translation),
             'quaternion_xyzw': list(t.quaternion())} for t in transforms]
    out = Path(path)
    out.write_text(yaml.safe_dump({'transforms': rows}, sort_keys=False))
    return out


def load_frames(path: str | Path) -> list[Transform]:
    """Read :func:`save_frames` YAML.

    Raises:
        DempathError: missing file or a malformed entry (names the file and the entry).
    """
    try:
        rows = yaml.safe_load(Path(path).read_text())['transforms']
        return [Transform.of(r['parent'], r['child'], r['translation'],
                             matrix_from_quaternion(*r['quaternion_xyzw'])) for r in rows]
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as err:
        msg = f'{path}: not a frames file ({type(err).__name__}: {err})'
        raise DempathError(msg) from err


def check_tree(transforms: list[Transform], root: str = WORLD) -> dict[str, str]:
    """child -> parent of a tree rooted at ``root``: one parent per frame, no cycle.

    Raises:
        ValueError: a frame with two parents, or one not connected to ``root``.
    """
    parent: dict[str, str] = {}
    for t in transforms:
        if parent.get(t.child, t.parent) != t.parent:
            msg = f'frame {t.child!r} has two parents: {parent[t.child]!r} and {t.parent!r}'
            raise ValueError(msg)
        parent[t.child] = t.parent
    for frame in parent:
        seen, at = {frame}, frame
        while at != root:
            if at not in parent or parent[at] in seen:
                msg = f'frame {frame!r} does not reach {root!r}'
                raise ValueError(msg)
            at = parent[at]
            seen.add(at)
    return parent


def tf_message(store: Any, transforms: list[Transform], stamp_ns: int) -> Any:
    """A rosbags ``tf2_msgs/msg/TFMessage`` of ``transforms`` stamped ``stamp_ns``."""
    types = store.types
    stamp = types['builtin_interfaces/msg/Time'](sec=stamp_ns // 10**9,
                                                 nanosec=stamp_ns % 10**9)
    out = []
    for t in transforms:
        x, y, z, w = t.quaternion()
        out.append(types['geometry_msgs/msg/TransformStamped'](
            header=types['std_msgs/msg/Header'](stamp=stamp, frame_id=t.parent),
            child_frame_id=t.child,
            transform=types['geometry_msgs/msg/Transform'](
                translation=types['geometry_msgs/msg/Vector3'](*t.translation),
                rotation=types['geometry_msgs/msg/Quaternion'](x=x, y=y, z=z, w=w))))
    return types[TF_TYPE](transforms=out)


def pose_tf_cdr(store: Any, pose_stamped_cdr: bytes, child: str = TOOL) -> bytes:
    """CDR of a TFMessage placing ``child`` at a ``geometry_msgs/PoseStamped`` (its stamp, its
    frame as parent), from the pose's CDR."""
    pose = store.deserialize_cdr(pose_stamped_cdr, 'geometry_msgs/msg/PoseStamped')
    types = store.types
    p, q = pose.pose.position, pose.pose.orientation
    msg = types[TF_TYPE](transforms=[types['geometry_msgs/msg/TransformStamped'](
        header=pose.header, child_frame_id=child,
        transform=types['geometry_msgs/msg/Transform'](
            translation=types['geometry_msgs/msg/Vector3'](x=p.x, y=p.y, z=p.z), rotation=q))])
    return bytes(store.serialize_cdr(msg, TF_TYPE))
