"""Frames as TF: rotations, the camera transform, the tree, and the recorder's /tf_static + /tf
read back from the MCAP with the mcap package's own ROS 2 decoder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from dempath.frames import (
    SCENE_IN_WORLD,
    Transform,
    camera_transform,
    check_tree,
    load_frames,
    matrix_from_quaternion,
    quaternion_from_matrix,
    save_frames,
    scene_transforms,
)
from dempath.recording import BagRecorder, RecorderConfig
from dempath.typestore import make_typestore


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random proper rotation (QR of a Gaussian matrix, signs fixed)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    return q if np.linalg.det(q) > 0 else -q


def test_quaternion_round_trip() -> None:
    """matrix -> quaternion -> matrix is exact for random rotations and the half turns."""
    rng = np.random.default_rng(1)
    for rot in [random_rotation(rng) for _ in range(300)] + [np.diag([1.0, -1, -1]),
                                                                np.diag([-1.0, 1, -1]),
                                                                np.diag([-1.0, -1, 1])]:
        q = quaternion_from_matrix(rot)
        assert abs(np.linalg.norm(q) - 1) < 1e-12 and q[3] >= 0
        np.testing.assert_allclose(matrix_from_quaternion(*q), rot, atol=1e-12)


def test_scene_is_the_paper_frame_turned_z_up() -> None:
    """REP 103 world: the paper's travel (+Z) is forward (+X), its up (+Y) is up (+Z)."""
    np.testing.assert_array_equal(SCENE_IN_WORLD @ [0, 0, 1], [1, 0, 0])
    np.testing.assert_array_equal(SCENE_IN_WORLD @ [0, 1, 0], [0, 0, 1])
    np.testing.assert_array_equal(SCENE_IN_WORLD @ [1, 0, 0], [0, 1, 0])
    assert np.linalg.det(SCENE_IN_WORLD) == 1


def test_camera_transform_inverts_the_extrinsics() -> None:
    """A point's camera coordinates (x = R p + t) map back to p through the optical frame."""
    rng = np.random.default_rng(2)
    rot, t = random_rotation(rng), rng.normal(size=3)
    tf = camera_transform('cam_side', rot, t)
    assert (tf.parent, tf.child) == ('field', 'cam_side_optical')
    p = rng.normal(size=3)
    np.testing.assert_allclose(tf.matrix() @ np.append(rot @ p + t, 1.0), np.append(p, 1.0),
                               atol=1e-12)


def test_tree_checks(tmp_path: Path) -> None:
    """One parent per frame, every frame reaching world; the YAML round trip keeps the poses."""
    tree = [*scene_transforms([0.1, 0.0, 0.2]), camera_transform('cam_side', np.eye(3),
                                                                  [0, 0, 1])]
    assert check_tree(tree) == {'scene': 'world', 'field': 'scene', 'cam_side_optical': 'field'}
    with pytest.raises(ValueError, match='two parents'):
        check_tree([*tree, Transform.of('scene', 'cam_side_optical', [0, 0, 0])])
    with pytest.raises(ValueError, match='does not reach'):
        check_tree([*tree, Transform.of('elsewhere', 'tool', [0, 0, 0])])
    back = load_frames(save_frames(tmp_path / 'frames.yaml', tree))
    for a, b in zip(tree, back, strict=True):
        np.testing.assert_allclose(a.matrix(), b.matrix(), atol=1e-12)


def _decoded(bag: Path) -> dict[str, list[tuple[int, object]]]:
    out: dict[str, list[tuple[int, object]]] = {}
    for path in bag.glob('*.mcap'):
        with path.open('rb') as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for _, channel, message, decoded in reader.iter_decoded_messages():
                out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out


def test_recorder_writes_tf_static_and_the_tool_on_tf(tmp_path: Path) -> None:
    """The frames file lands on /tf_static once; each tool pose also on /tf with its stamp."""
    frames = save_frames(tmp_path / 'frames.yaml', scene_transforms([0.1, 0.0, 0.2]))
    store = make_typestore()
    recorder = BagRecorder(RecorderConfig(output=str(tmp_path / 'bag'), frames_file=str(frames),
                                          tool_pose_topic='/sim/tool_pose'), store)
    recorder.open()
    recorder.add_topic('/sim/tool_pose', 'geometry_msgs/msg/PoseStamped')
    types = store.types
    for k in range(3):
        stamp = types['builtin_interfaces/msg/Time'](sec=100 + k, nanosec=5)
        pose = types['geometry_msgs/msg/PoseStamped'](
            header=types['std_msgs/msg/Header'](stamp=stamp, frame_id='scene'),
            pose=types['geometry_msgs/msg/Pose'](
                position=types['geometry_msgs/msg/Point'](x=0.0, y=-0.1, z=0.3 - 0.1 * k),
                orientation=types['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0, w=1.0)))
        data = bytes(store.serialize_cdr(pose, 'geometry_msgs/msg/PoseStamped'))
        recorder.submit('/sim/tool_pose', data, 10**9 * (100 + k))
    recorder.close()
    got = _decoded(tmp_path / 'bag')
    (static,) = got['/tf_static']
    pairs = [(t.header.frame_id, t.child_frame_id) for t in static[1].transforms]
    assert pairs == [('world', 'scene'), ('scene', 'field')]
    q = static[1].transforms[0].transform.rotation
    assert (q.x, q.y, q.z, q.w) == pytest.approx((0.5, 0.5, 0.5, 0.5))
    tool = [msg.transforms[0] for _, msg in got['/tf']]
    assert [(t.header.frame_id, t.child_frame_id) for t in tool] == [('scene', 'tool')] * 3
    assert [(t.header.stamp.sec, t.header.stamp.nanosec) for t in tool] == [(100, 5), (101, 5),
                                                                             (102, 5)]
    assert [t.transform.translation.z for t in tool] == pytest.approx([0.3, 0.2, 0.1])
    assert recorder.stats['/tf'].written == 3 and recorder.stats['/tf_static'].written == 1
