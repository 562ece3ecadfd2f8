"""bag -> player -> recorder -> new bag: identical payloads and header stamps, in one process."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import StoragePlugin, Writer
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, CompressedImage

from dempath import topics
from dempath.bagio import open_bag, write_bag
from dempath.nodes.harness import RosHarness
from dempath.nodes.pipeline import replay_and_record
from dempath.nodes.player import PlayerNode
from dempath.nodes.recorder import RecorderNode
from dempath.testbags import START_NS, header, images, pixel_points
from dempath.typestore import make_typestore
from dempath_msgs.msg import PixelPoints, RunEvent

LATCHED = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def make_input_bag(path: Path, storage: str = 'mcap') -> Path:
    """Two cameras' PixelPoints (dempath_msgs) and small JPEG frames, interleaved, 20 ms apart."""
    store = make_typestore()
    msgs = [*pixel_points(store, 12, camera='cam_side', seed=1),
            *pixel_points(store, 12, camera='cam_front', seed=2),
            *images(store, 12, 160, 90, camera='cam_side', jpeg=True, seed=3)]
    return write_bag(path, sorted(msgs, key=lambda m: m[2]), typestore=store, storage=storage)


def by_topic(bag_path: Path) -> dict[str, list[bytes]]:
    """Every message's CDR bytes per topic, in bag order."""
    out: dict[str, list[bytes]] = {}
    with open_bag(bag_path) as bag:
        for message in bag.messages():
            out.setdefault(message.topic, []).append(message.data)
    return out


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_round_trip_identical_payloads_and_stamps(tmp_path: Path, storage: str) -> None:
    """Every played message is recorded byte for byte, so its header stamp is unchanged."""
    source = make_input_bag(tmp_path / 'in', storage)
    wanted = sorted(by_topic(source))
    result = replay_and_record(source, tmp_path / 'out', wanted, rate=1.0, timeout_s=60)
    assert result.complete, result.summary
    sent, got = by_topic(source), by_topic(tmp_path / 'out')
    assert sorted(got) == wanted
    for topic in wanted:
        assert got[topic] == sent[topic], topic
    with open_bag(tmp_path / 'out') as bag:
        stamps = [bag.deserialize(m).header.stamp for m in bag.messages([wanted[0]])]
    assert [s.sec * 10**9 + s.nanosec for s in stamps] == \
        [START_NS + i * 20_000_000 for i in range(12)]
    assert all(s.dropped == 0 and s.written == s.received for s in result.recorded.values())


def test_clock_events_and_default_topics(tmp_path: Path, ros_harness: RosHarness) -> None:
    """/clock carries bag time, FINISHED is latched, and the default recorder skips /clock."""
    source = make_input_bag(tmp_path / 'in')
    clocks = ros_harness.collect(Clock, topics.CLOCK)
    recorder = ros_harness.start(RecorderNode, output=str(tmp_path / 'out'))
    ros_harness.spin_for(0.2)
    player = ros_harness.start(PlayerNode, bag=str(source), rate=0.0, wait_for_subscribers=1)
    assert ros_harness.spin_until(player.finished.is_set, timeout_s=30)
    events = ros_harness.collect(RunEvent, topics.PLAYER_EVENTS, LATCHED)
    assert ros_harness.spin_until(
        lambda: any(e.event == RunEvent.FINISHED for e in events), timeout_s=10)
    assert 'published 36 messages' in events[-1].detail
    assert ros_harness.spin_until(lambda: sum(
        s.received for s in recorder.recorder.stats.values()) >= 36 + 2, timeout_s=10)
    recorder.finish()
    assert clocks, 'no /clock message'
    assert all(START_NS <= c.clock.sec * 10**9 + c.clock.nanosec <= START_NS + 11 * 20_000_000
               for c in clocks)
    recorded = by_topic(tmp_path / 'out')
    assert topics.CLOCK not in recorded
    assert recorded['/cam_side/pixel_points'] == by_topic(source)['/cam_side/pixel_points']
    assert len(recorded[topics.PLAYER_EVENTS]) == 2  # STARTED and FINISHED
    with open_bag(tmp_path / 'out') as bag:  # the publishers' QoS is kept in the bag
        assert bag.topics[topics.PLAYER_EVENTS].latched
        assert not bag.topics['/cam_side/pixel_points'].latched


def test_latched_topic_reaches_late_subscriber(tmp_path: Path, ros_harness: RosHarness) -> None:
    """A topic recorded as transient local is replayed latched: a late subscriber gets it."""
    store = make_typestore()
    info = store.types['sensor_msgs/msg/CameraInfo'](
        header=header(store, START_NS, 'cam_side'), height=1080, width=1920,
        distortion_model='plumb_bob', d=np.zeros(5), k=np.eye(3).ravel(), r=np.eye(3).ravel(),
        p=np.zeros(12), binning_x=0, binning_y=0,
        roi=store.types['sensor_msgs/msg/RegionOfInterest'](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
    latched = Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE,
                  QosDurability.TRANSIENT_LOCAL, QosTime(0, 0), QosTime(0, 0),
                  QosLiveliness.AUTOMATIC, QosTime(0, 0), False)
    topic = topics.camera_topic(topics.CAMERA_INFO, 'cam_side')
    with Writer(tmp_path / 'in', version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection(topic, 'sensor_msgs/msg/CameraInfo', typestore=store,
                                     offered_qos_profiles=[latched])
        writer.write(conn, START_NS, store.serialize_cdr(info, 'sensor_msgs/msg/CameraInfo'))
    player = ros_harness.start(PlayerNode, bag=str(tmp_path / 'in'), rate=0.0)
    assert ros_harness.spin_until(player.finished.is_set, timeout_s=10)
    got = ros_harness.collect(CameraInfo, topic, LATCHED)
    assert ros_harness.spin_until(lambda: len(got) == 1, timeout_s=10)
    assert (got[0].width, got[0].header.frame_id) == (1920, 'cam_side')


def test_player_finishes_only_when_every_message_is_acknowledged(
        tmp_path: Path, ros_harness: RosHarness) -> None:
    """A slow reliable subscriber: the player's FINISHED event comes once the subscriber has
    acknowledged every message, and says so; the player node destroyed at that moment (as the
    console script exits) loses nothing. (On a loaded machine the player used to exit with the
    last frames unsent.)"""
    source = make_input_bag(tmp_path / 'in')
    keep_all = QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL,
                          reliability=ReliabilityPolicy.RELIABLE)
    got: list[object] = []

    def slow(msg: object) -> None:
        time.sleep(0.01)
        got.append(msg)

    ros_harness.probe.create_subscription(CompressedImage, '/cam_side/image_raw/compressed',
                                          slow, keep_all)
    events = ros_harness.collect(RunEvent, topics.PLAYER_EVENTS, LATCHED)
    player = ros_harness.start(PlayerNode, bag=str(source), rate=0.0, wait_for_subscribers=1,
                               topics=['/cam_side/image_raw/compressed'])
    assert ros_harness.spin_until(player.finished.is_set, timeout_s=30)
    ros_harness.nodes.remove(player)
    ros_harness.executor.remove_node(player)  # as the console script exits
    player.destroy_node()
    assert ros_harness.spin_until(lambda: len(got) == 12, timeout_s=10), len(got)
    assert ros_harness.spin_until(
        lambda: any(e.event == RunEvent.FINISHED for e in events), timeout_s=10)
    assert 'every message acknowledged' in events[-1].detail, events[-1].detail


def test_player_waits_for_every_reader_it_is_told_of(tmp_path: Path,
                                                     ros_harness: RosHarness) -> None:
    """A topic read by a node and a recorder: the player's publisher matches them one by one, so
    it waits for the count given per topic (``wait_topic_subscribers``) and a recorder started
    after the player still gets the first message. (The graph's recorder lost the first side image
    on a loaded machine when the player waited for its first reader only.)"""
    source = make_input_bag(tmp_path / 'in')
    topic = '/cam_side/pixel_points'
    got = ros_harness.collect(PixelPoints, topic, 50)  # the first reader, there at once
    player = ros_harness.start(PlayerNode, bag=str(source), rate=0.0, topics=[topic],
                               wait_for_subscribers=1, wait_topic_subscribers=[f'{topic}=2'])
    recorder = ros_harness.start(RecorderNode, output=str(tmp_path / 'out'), topics=[topic])
    assert ros_harness.spin_until(
        lambda: player.finished.is_set() and len(got) == 12
        and recorder.recorder.stats[topic].received == 12, timeout_s=30), recorder.recorder.stats
    assert recorder.subscribed_to(topic)
    recorder.finish()
    assert by_topic(tmp_path / 'out')[topic] == by_topic(source)[topic]


def test_player_short_of_readers_plays_and_names_the_topic(
        tmp_path: Path, ros_harness: RosHarness, capfd: pytest.CaptureFixture[str]) -> None:
    """Fewer readers than waited for: after ``wait_timeout_s`` it plays anyway and one warning
    names the topic and the counts; a malformed per-topic count aborts with one error line."""
    source = make_input_bag(tmp_path / 'in')
    topic = '/cam_front/pixel_points'
    got = ros_harness.collect(PixelPoints, topic, 50)
    player = ros_harness.start(PlayerNode, bag=str(source), rate=0.0, topics=[topic],
                               wait_topic_subscribers=[f'{topic}=3'], wait_timeout_s=0.5)
    assert ros_harness.spin_until(lambda: player.finished.is_set() and len(got) == 12,
                                  timeout_s=30)
    bad = ros_harness.start(PlayerNode, bag=str(source), wait_topic_subscribers=['front=2'])
    assert bad.finished.is_set()
    err = capfd.readouterr().err
    assert f'{topic}: playing with 1 of the 3 subscribers waited for' in err, err
    assert "wait_topic_subscribers: 'front=2' is not TOPIC=N" in err, err
