"""The demo's node graph end to end on a few field-twin frames and the tiny scene, and the
frames (TF) and standard messages of the bag it records (docs/ros.md, "Frames")."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from dempath import topics
from dempath.bagio import write_bag
from dempath.frames import SCENE_IN_WORLD, Transform, check_tree, matrix_from_quaternion
from dempath.typestore import make_typestore
from dempath_bringup.frames import marker_grid_centre
from dempath_bringup.nodes.graph import GraphResult, GraphSpec, field_truth_error, run_graph
from dempath_sim.scene.loader import resolve_scene
from dempath_twin.field import markers as ft
from dempath_twin.rig import paper_rig

ROOT = Path(__file__).resolve().parents[1]
TRUTH = ROOT / 'bags' / 'field_twin_tiny.truth.csv'
STRIDE = 3  # every 3rd frame of the shipped field twin: a few frames over the whole motion


def few_frames_bag(tmp_path: Path) -> tuple[Path, Path, int]:
    """A field bag of every STRIDE-th truth frame with fresh clicking noise, and its truth CSV."""
    truth = ft.read_marker_csv(TRUTH)
    tracks = ft.MarkerTracks(truth.times[::STRIDE], truth.marker_ids, truth.xyz[::STRIDE])
    rig, config = paper_rig(), ft.FieldTwinConfig(seed=3, image_scale=0.25)
    clicked = ft.click_noise(ft.project_tracks(rig.cameras, tracks.xyz), config.sigma_px,
                             np.random.default_rng(3))
    store = make_typestore()
    bag = write_bag(tmp_path / 'field', ft.field_messages(tracks, rig.cameras, clicked, config,
                                                          store.types), typestore=store)
    return bag, ft.write_truth_csv(tmp_path / 'truth.csv', tracks), len(tracks.times)


def mcap_topic_counts(bag: Path) -> Counter[str]:
    """Messages per topic, read with the mcap package's own reader (not rosbags)."""
    counts: Counter[str] = Counter()
    for path in bag.glob('*.mcap'):
        with path.open('rb') as f:
            for _, channel, _ in make_reader(f).iter_messages():
                counts[channel.topic] += 1
    return counts


def test_graph_reconstructs_simulates_and_scores(tmp_path: Path) -> None:
    """Clicks -> 3D within a few mm of the truth; the tiny run is scored for all 15 markers;
    the bag has its frames and standard messages."""
    field, truth_csv, frames = few_frames_bag(tmp_path)
    calibration = paper_rig().save(tmp_path / 'stereo.yaml')
    spec = GraphSpec(field_bag=field, calibration=calibration, scene='tiny',
                     output=tmp_path / 'run', experiment='field_twin', sim_timeout_s=300.0)
    result = run_graph(spec)
    assert result.pixel_frames == frames
    assert result.received[topics.MARKER_POINTS] == frames
    mean_mm, max_mm, _ = field_truth_error(result.bag, truth_csv)
    assert mean_mm < 5.0, f'mean 3D error {mean_mm:.2f} mm'
    assert max_mm < 15.0, f'max 3D error {max_mm:.2f} mm'
    assert result.scored_markers == 15
    assert result.scores >= 15
    assert result.sim_frames > 10
    assert result.live is not None and len(result.live.measured) == 15  # the node's own scores
    counts = mcap_topic_counts(result.bag)
    assert counts[topics.MARKER_POINTS] == frames
    assert counts[topics.SIM_STATES] == result.sim_frames
    assert counts[topics.COMPARE_SCORES] >= 1
    assert counts[topics.SIM_RUN_EVENTS] >= 2  # STARTED and FINISHED
    assert counts[topics.camera_topic(topics.PIXEL_POINTS, 'cam_side')] == frames
    check_frames_and_standard_messages(result)


def recorded_frames(bag: Path) -> tuple[list[Transform], list[tuple[int, str, str]], dict]:
    """(static transforms, (stamp ns, parent, child) of /tf, every header frame id per topic)."""
    static, dynamic, frame_ids = [], [], {}
    with AnyReader([bag]) as reader:  # types from the bag itself
        for conn, _, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.topic in ('/tf_static', '/tf'):
                for t in msg.transforms:
                    r, p = t.transform.rotation, t.transform.translation
                    tf = Transform.of(t.header.frame_id, t.child_frame_id, [p.x, p.y, p.z],
                                      matrix_from_quaternion(r.x, r.y, r.z, r.w))
                    stamp = t.header.stamp.sec * 10**9 + t.header.stamp.nanosec
                    (static.append(tf) if conn.topic == '/tf_static'
                     else dynamic.append((stamp, tf.parent, tf.child)))
            elif hasattr(msg, 'header'):
                frame_ids.setdefault(conn.topic, set()).add(msg.header.frame_id)
            elif hasattr(msg, 'markers'):
                frame_ids.setdefault(conn.topic, set()).update(m.header.frame_id
                                                               for m in msg.markers)
    return static, dynamic, frame_ids


def check_frames_and_standard_messages(result: GraphResult) -> None:
    """The recorded bag's TF: world -> scene (Y up turned Z up) -> field (grid centre) -> both
    cameras where the calibration puts them; the tool on /tf at every tool pose's stamp; every
    stamped message in a frame of the tree; the force as WrenchStamped, the particles as a
    PointCloud2 with radii."""
    rig = paper_rig()
    static, dynamic, frame_ids = recorded_frames(result.bag)
    tree = check_tree(static + [Transform.of(p, c, [0, 0, 0]) for _, p, c in dynamic[:1]])
    assert tree == {'scene': 'world', 'field': 'scene', 'cam_side_optical': 'field',
                    'cam_front_optical': 'field', 'tool': 'scene'}
    pose = {t.child: t for t in static}
    np.testing.assert_allclose(pose['scene'].rotation, SCENE_IN_WORLD, atol=1e-12)
    origin = marker_grid_centre(resolve_scene('tiny').markers)
    np.testing.assert_allclose(pose['field'].translation, origin, atol=1e-12)
    for cam in rig.cameras:  # camera pose = the calibration's: centre -R^T t, axes R^T
        tf = pose[f'{cam.name}_optical']
        np.testing.assert_allclose(tf.translation, cam.center, atol=1e-9)
        np.testing.assert_allclose(tf.rotation, cam.R.T, atol=1e-9)
        in_world = SCENE_IN_WORLD @ (origin + cam.center)
        assert in_world[2] > 0.0, f'{cam.name} is below the sand in world: {in_world}'
    with AnyReader([result.bag]) as reader:
        pose_stamps = [reader.deserialize(raw, c.msgtype).header.stamp for c, _, raw
                       in reader.messages([c for c in reader.connections
                                           if c.topic == topics.SIM_TOOL_POSE])]
    assert [t for t, _, _ in dynamic] == [s.sec * 10**9 + s.nanosec for s in pose_stamps]
    known = set(tree) | {'world'}
    for topic in (topics.MARKER_POINTS, topics.SIM_STATES, topics.SIM_VIZ, topics.COMPARE_VIZ,
                  topics.SIM_TOOL_POSE, topics.SIM_TOOL_WRENCH, topics.SIM_CLOUD):
        assert frame_ids.get(topic, set()) <= known, (topic, frame_ids.get(topic))
    assert frame_ids[topics.MARKER_POINTS] == {'field'}
    assert frame_ids[topics.SIM_STATES] == {'scene'}
    counts = mcap_topic_counts(result.bag)
    assert counts[topics.SIM_TOOL_WRENCH] == counts[topics.SIM_TOOL_FORCE] == result.sim_frames
    assert counts[topics.SIM_CLOUD] == counts[topics.SIM_VIZ] > 0
    with AnyReader([result.bag]) as reader:
        conns = [c for c in reader.connections if c.topic == topics.SIM_CLOUD]
        cloud = reader.deserialize(next(iter(reader.messages(conns)))[2], conns[0].msgtype)
    assert [f.name for f in cloud.fields] == ['x', 'y', 'z', 'radius', 'marker_id']
    points = np.frombuffer(bytes(cloud.data), dtype=[('x', '<f4'), ('y', '<f4'), ('z', '<f4'),
                                                     ('radius', '<f4'), ('marker_id', '<i4')])
    assert len(points) == cloud.width > 0 and (points['radius'] > 0).all()
    assert set(points['marker_id'][points['marker_id'] > 0]) == set(range(1, 16))
