"""playback: messages reach the sink in order, never before they are due, with loop and stop."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

from dempath.bagio import RawMessage, open_bag, write_bag
from dempath.mcapbag import McapBagWriter
from dempath.playback import Playback, PlayerConfig
from dempath.testbags import START_NS, pixel_points
from dempath.typestore import make_typestore


@pytest.fixture
def two_camera_bag(tmp_path: Path) -> Path:
    """10 PixelPoints per camera, 20 ms apart, interleaved by time."""
    store = make_typestore()
    msgs = [*pixel_points(store, 10, camera='cam_side', seed=1),
            *pixel_points(store, 10, camera='cam_front', seed=2)]
    return write_bag(tmp_path / 'bag', sorted(msgs, key=lambda m: m[2]), typestore=store)


def play(bag_path: Path, **params: object) -> tuple[list[RawMessage], list[float], object]:
    """Run a playback to the end; return the messages, their sink times [s] and the stats."""
    config = PlayerConfig(bag=str(bag_path), **params)  # type: ignore[arg-type]
    got: list[RawMessage] = []
    times: list[float] = []
    with open_bag(bag_path, config.topics) as bag:
        playback = Playback(bag, config, [t.name for t in bag.select(config.topics)])
        start = time.monotonic()
        stats = playback.run(lambda m: (got.append(m), times.append(time.monotonic() - start)))
    return got, times, stats


def test_original_timing_is_a_lower_bound(two_camera_bag: Path) -> None:
    """At rate 2 no message is handed over before (t - t0) / 2 after the start."""
    got, times, stats = play(two_camera_bag, rate=2.0)
    assert len(got) == 20 and stats.total == 20 and stats.error is None
    for message, t_s in zip(got, times, strict=True):
        assert t_s >= (message.log_time_ns - START_NS) * 1e-9 / 2.0 - 1e-3


def test_slow_sink_is_reported_behind_schedule(two_camera_bag: Path) -> None:
    """A sink slower than the bag's pace is not hidden: messages are counted behind schedule."""
    config = PlayerConfig(bag=str(two_camera_bag), rate=1.0)
    with open_bag(two_camera_bag) as bag:
        stats = Playback(bag, config, sorted(bag.topics)).run(lambda _: time.sleep(0.05))
    assert stats.total == 20
    assert stats.behind >= 10  # 20 messages in 0.2 s of bag time take at least 1 s
    assert stats.max_lag_s >= 0.5


def test_bag_order_and_bytes_preserved(two_camera_bag: Path) -> None:
    """Rate 0 plays everything, in bag-time order, byte for byte."""
    got, _, stats = play(two_camera_bag, rate=0.0)
    with open_bag(two_camera_bag) as bag:
        assert got == list(bag.messages())
    assert stats.behind == 0 and stats.max_lag_s == 0.0  # type: ignore[attr-defined]


def test_offset_and_topics(two_camera_bag: Path) -> None:
    """The start offset and the topic selection both apply."""
    got, _, stats = play(two_camera_bag, rate=0.0, start_offset_s=0.1,
                         topics=('/cam_front/pixel_points',))
    assert stats.published == {'/cam_front/pixel_points': 5}
    assert [m.log_time_ns for m in got] == [START_NS + i * 20_000_000 for i in range(5, 10)]


def test_loop_until_stopped(two_camera_bag: Path) -> None:
    """With loop the bag plays again and again until stop is set from another thread."""
    config = PlayerConfig(bag=str(two_camera_bag), rate=0.0, loop=True)
    with open_bag(two_camera_bag) as bag:
        playback = Playback(bag, config, sorted(bag.topics))
        count = 0

        def sink(_: RawMessage) -> None:
            nonlocal count
            count += 1
            if count == 50:
                playback.stop.set()

        runner = threading.Thread(target=lambda: setattr(playback, 'result', playback.run(sink)))
        runner.start()
        runner.join(timeout=30)
    assert not runner.is_alive()
    assert count == 50
    assert playback.result.loops == 2  # type: ignore[attr-defined]


def test_damaged_chunk_stops_playback_with_error(tmp_path: Path) -> None:
    """A damaged zstd chunk ends playback after the good chunk with one line naming the file."""
    store = make_typestore()
    writer = McapBagWriter(tmp_path / 'bag', compression='zstd')
    writer.open()
    channel = writer.add_topic('/cam_side/pixel_points', 'dempath_msgs/msg/PixelPoints', '')
    for batch in range(3):
        for _, msgtype, t_ns, msg in pixel_points(store, 5, start_ns=START_NS + batch * 10**8):
            writer.write(channel, t_ns, bytes(store.serialize_cdr(msg, msgtype)))
        writer.flush()
    writer.close()
    data = bytearray(writer.mcap_path.read_bytes())
    second_chunk = data.index(b'zstd', data.index(b'zstd') + 4)  # compression name of chunk 2
    data[second_chunk + 20:second_chunk + 120] = b'\xff' * 100
    writer.mcap_path.write_bytes(bytes(data))
    got, _, stats = play(tmp_path / 'bag', rate=0.0)
    assert len(got) == 5  # the first chunk
    assert stats.error == (f'{writer.mcap_path}: corrupt data after 5 messages (Unable to '
                           'decompress Zstandard data: Data corruption detected)')


def test_file_cut_during_playback_stops_with_error(two_camera_bag: Path) -> None:
    """A file that loses its data after opening ends playback with one error, no crash."""
    config = PlayerConfig(bag=str(two_camera_bag), rate=0.0)
    mcap = next(two_camera_bag.glob('*.mcap'))
    with open_bag(two_camera_bag) as bag:
        with mcap.open('r+b') as stream:
            stream.truncate(200)
        stats = Playback(bag, config, sorted(bag.topics)).run(lambda _: None)
    assert stats.total == 0
    assert stats.error is not None
    assert f'{mcap}: corrupt data after 0 messages' in stats.error and '\n' not in stats.error


@pytest.mark.parametrize('field, value', [('bag', ''), ('rate', -1.0), ('queue_depth', 0),
                                          ('wait_topic_subscribers', ('/a=two',)),
                                          ('wait_topic_subscribers', ('a=2',))])
def test_config_validation(field: str, value: object) -> None:
    """Bad settings name the field and the value."""
    params = {'bag': 'x', field: value}
    with pytest.raises(ValueError, match=field):
        PlayerConfig(**params)  # type: ignore[arg-type]


def test_per_topic_subscriber_counts() -> None:
    """``wait_topic_subscribers`` overrides the common count for the topics it names."""
    config = PlayerConfig.from_params(bag='x', wait_for_subscribers=1,
                                      wait_topic_subscribers=['/cam/a=3', ''])
    assert config.subscribers_needed('/cam/a') == 3
    assert config.subscribers_needed('/cam/b') == 1
