"""Bad bags and outputs: one clear error line, exit 1 from the CLI, no harm to other nodes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosbags.typesys import get_types_from_msg

from dempath import topics
from dempath.bagio import open_bag, write_bag
from dempath.cli import main as dempath
from dempath.nodes.harness import RosHarness
from dempath.nodes.player import PlayerNode
from dempath.nodes.recorder import RecorderNode
from dempath.testbags import START_NS, pixel_points
from dempath.typestore import make_typestore
from dempath_msgs.msg import RunEvent

LATCHED = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
GHOST_MSG = 'float64 value\n'
GHOST_TOPIC = '/sim/ghost'


def points_bag(path: Path, count: int = 8, camera: str = 'cam_side') -> Path:
    """``count`` PixelPoints of one camera."""
    return write_bag(path, pixel_points(make_typestore(), count, camera=camera))


def truncated_bag(path: Path) -> Path:
    """A points bag whose .mcap lost its last 200 bytes."""
    points_bag(path)
    mcap = next(path.glob('*.mcap'))
    mcap.write_bytes(mcap.read_bytes()[:-200])
    return path


def ghost_bag(path: Path) -> Path:
    """PixelPoints plus a topic whose type exists only in the bag (no Python package)."""
    store = make_typestore()
    store.register(get_types_from_msg(GHOST_MSG, 'ghost_msgs/msg/Ghost'))
    ghost = store.types['ghost_msgs/msg/Ghost']
    msgs = [*pixel_points(store, 8, camera='cam_front'),
            *[(GHOST_TOPIC, 'ghost_msgs/msg/Ghost', START_NS + i, ghost(value=float(i)))
              for i in range(3)]]
    return write_bag(path, sorted(msgs, key=lambda m: m[2]), typestore=store)


def error_lines(text: str) -> list[str]:
    """Lines that report an error (CLI ``error:`` or ROS ``[ERROR]``)."""
    return [line for line in text.splitlines() if line.startswith('error:') or '[ERROR]' in line]


@pytest.mark.parametrize('case', ['truncated', 'missing', 'no_metadata', 'missing_topic',
                                  'unknown_type', 'unwritable'])
def test_cli_one_error_line(case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Each bad input gives exit 1 and exactly one error line naming the input."""
    bag = tmp_path / 'bag'
    if case == 'truncated':
        argv, needle = ['bag-info', str(truncated_bag(bag))], 'truncated or corrupt'
    elif case == 'missing':
        argv, needle = ['play', str(bag)], 'no such bag'
    elif case == 'no_metadata':
        (points_bag(bag) / 'metadata.yaml').unlink()
        argv, needle = ['play', str(bag)], 'no metadata.yaml'
    elif case == 'missing_topic':
        argv, needle = ['play', str(points_bag(bag)), '--topics', '/nope'], '/nope not in bag'
    elif case == 'unknown_type':
        argv, needle = ['play', str(ghost_bag(bag))], 'ghost_msgs/msg/Ghost cannot be imported'
    else:
        (tmp_path / 'file').write_text('x')
        bag = tmp_path / 'file' / 'bag'
        argv, needle = ['record', '-o', str(bag)], 'not a writable directory'
    assert dempath(argv) == 1
    lines = error_lines(capsys.readouterr().err)
    assert len(lines) == 1, lines
    assert needle in lines[0] and str(bag) in lines[0]


def test_bad_nodes_do_not_harm_others(tmp_path: Path, ros_harness: RosHarness,
                                      capfd: pytest.CaptureFixture[str]) -> None:
    """A bad bag, an unknown type and an unwritable output each log one line; the rest records."""
    good = ros_harness.start(RecorderNode, output=str(tmp_path / 'good'),
                             topics=['/cam_front/pixel_points', '/cam_side/pixel_points'])
    (tmp_path / 'file').write_text('x')
    stuck = ros_harness.start(RecorderNode, output=str(tmp_path / 'file' / 'bag'))
    assert stuck.recorder is None
    events = ros_harness.collect(RunEvent, topics.PLAYER_EVENTS, LATCHED)
    broken = ros_harness.start(PlayerNode, bag=str(truncated_bag(tmp_path / 'broken')))
    assert broken.finished.is_set()
    assert ros_harness.spin_until(lambda: any(e.event == RunEvent.ABORTED for e in events))
    player = ros_harness.start(PlayerNode, bag=str(ghost_bag(tmp_path / 'ghost')), rate=0.0,
                               wait_for_subscribers=1)
    assert ros_harness.spin_until(player.finished.is_set, timeout_s=30)
    assert player.stats.published == {'/cam_front/pixel_points': 8}
    assert ros_harness.spin_until(
        lambda: good.recorder.stats['/cam_front/pixel_points'].received == 8, timeout_s=10)
    side = ros_harness.start(PlayerNode, bag=str(points_bag(tmp_path / 'side')), rate=0.0,
                             wait_for_subscribers=1)  # the graph still works after all that
    assert ros_harness.spin_until(
        lambda: side.finished.is_set()
        and good.recorder.stats['/cam_side/pixel_points'].received == 8, timeout_s=30)
    good.finish()
    with open_bag(tmp_path / 'good') as bag:
        assert {t: i.msgcount for t, i in bag.topics.items()} == {
            '/cam_front/pixel_points': 8, '/cam_side/pixel_points': 8}
        stamps = np.array([bag.deserialize(m).header.stamp.nanosec
                           for m in bag.messages(['/cam_front/pixel_points'])])
    np.testing.assert_array_equal(stamps, np.arange(8) * 20_000_000)
    lines = error_lines(capfd.readouterr().err)
    assert len(lines) == 3, lines
    assert any('not recording' in x and 'file/bag' in x for x in lines)
    assert any('truncated or corrupt' in x and 'broken' in x for x in lines)
    assert any(f'topic {GHOST_TOPIC} skipped' in x and 'ghost_msgs' in x for x in lines)
