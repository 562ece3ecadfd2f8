"""bagio: typestore with dempath_msgs, round trips through MCAP and sqlite3, one-line errors."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import get_types_from_idl, get_types_from_msg

from dempath import mcapread
from dempath.bagio import filter_bag, open_bag, write_bag
from dempath.errors import BagError
from dempath.mcapbag import McapBagWriter
from dempath.testbags import START_NS, images, pixel_points
from dempath.typestore import dempath_msg_dir, ensure_type, make_typestore, message_definition

BLOB_MSG = 'std_msgs/Header header\nfloat64[3] xyz\nstring note\n'


def make_points_bag(path: Path, count: int = 5, storage: str = 'mcap') -> Path:
    """A bag of ``count`` PixelPoints on /cam_side/pixel_points (seed 0)."""
    return write_bag(path, pixel_points(make_typestore(), count), storage=storage)


def test_typestore_has_every_dempath_type_with_rosidl_hash() -> None:
    """Each .msg is registered and its RIHS01 equals the hash rosidl generated."""
    store = make_typestore()
    msg_dir = dempath_msg_dir()
    for path in sorted(msg_dir.glob('*.msg')):
        msgtype = f'dempath_msgs/msg/{path.stem}'
        assert msgtype in store.fielddefs
        rosidl = path.with_suffix('.json')
        if rosidl.exists():
            desc = json.loads(rosidl.read_text())
            assert store.hash_rihs01(msgtype) == desc['type_hashes'][0]['hash_string']


def test_message_definition_has_dependencies() -> None:
    """The ros2msg text carries the definitions it depends on, as Foxglove needs."""
    text = message_definition(make_typestore(), 'dempath_msgs/msg/Diagnosis')
    assert 'MSG: dempath_msgs/EffectCandidate' in text
    assert 'MSG: std_msgs/Header' in text


def test_ensure_type_loads_installed_msg_files() -> None:
    """A type missing from the store is found among the installed .msg files, or reported."""
    store = make_typestore()
    assert ensure_type(store, 'rcl_interfaces/msg/Log')
    assert not ensure_type(store, 'no_such_msgs/msg/Nothing')


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_round_trip(tmp_path: Path, storage: str) -> None:
    """Written messages read back identical, in order, with their bag times."""
    store = make_typestore()
    sent = list(pixel_points(store, 7, seed=3))
    bag_path = write_bag(tmp_path / 'bag', sent, typestore=store, storage=storage)
    with open_bag(bag_path) as bag:
        got = list(bag.messages())
        assert [m.log_time_ns for m in got] == [t for _, _, t, _ in sent]
        for (_, _, _, msg), raw in zip(sent, got, strict=True):
            back = bag.deserialize(raw)
            np.testing.assert_array_equal(back.u, msg.u)
            assert back.header.stamp == msg.header.stamp
        assert bag.topics['/cam_side/pixel_points'].msgcount == 7


def test_start_offset_and_topic_selection(tmp_path: Path) -> None:
    """The offset skips early messages; a topic selection yields only that topic."""
    store = make_typestore()
    msgs = [*pixel_points(store, 10, camera='cam_side'),
            *pixel_points(store, 10, camera='cam_front')]
    bag_path = write_bag(tmp_path / 'bag', sorted(msgs, key=lambda m: m[2]), typestore=store)
    with open_bag(bag_path) as bag:
        late = list(bag.messages(['/cam_front/pixel_points'], start_offset_s=0.1))
    assert {m.topic for m in late} == {'/cam_front/pixel_points'}
    assert [m.log_time_ns for m in late] == [START_NS + i * 20_000_000 for i in range(5, 10)]


def test_filter_bag_keeps_what_the_rule_accepts_byte_for_byte(tmp_path: Path) -> None:
    """A camera dropped and a stamp window cut: the rest is copied unchanged, in order."""
    store = make_typestore()
    msgs = [*pixel_points(store, 10, camera='cam_side'),
            *pixel_points(store, 10, camera='cam_front')]
    src = write_bag(tmp_path / 'src', sorted(msgs, key=lambda m: m[2]), typestore=store)
    cut = START_NS + 100_000_000

    def keep(topic: str, stamp: int) -> bool:
        return 'cam_front' not in topic and stamp < cut

    dst = filter_bag(src, tmp_path / 'dst', keep)
    with open_bag(src) as a, open_bag(dst) as b:
        want = [m for m in a.messages()
                if keep(m.topic, (lambda h: h.sec * 10**9 + h.nanosec)(a.deserialize(m)
                                                                      .header.stamp))]
        got = list(b.messages())
    assert len(got) == 5 and got == want


def test_type_defined_only_in_bag_is_readable(tmp_path: Path) -> None:
    """A custom type known only from the bag's schema deserializes (as AnyReader would)."""
    writer_store = make_typestore()
    writer_store.register(get_types_from_msg(BLOB_MSG, 'blob_msgs/msg/Blob'))
    blob = writer_store.types['blob_msgs/msg/Blob']
    hdr = next(pixel_points(writer_store, 1))[3].header
    msg = blob(header=hdr, xyz=np.array([1.0, 2.0, 3.0]), note='only in this bag')
    bag_path = write_bag(tmp_path / 'bag', [('/sim/blob', 'blob_msgs/msg/Blob', START_NS, msg)],
                         typestore=writer_store)
    with open_bag(bag_path) as bag:
        back = bag.deserialize(next(bag.messages()))
    assert back.note == 'only in this bag'
    np.testing.assert_array_equal(back.xyz, [1.0, 2.0, 3.0])


def test_image_round_trip(tmp_path: Path) -> None:
    """A bgr8 Image keeps its pixels through a bag."""
    store = make_typestore()
    sent = list(images(store, 2, 64, 48))
    with open_bag(write_bag(tmp_path / 'bag', sent, typestore=store)) as bag:
        back = [bag.deserialize(m) for m in bag.messages()]
    np.testing.assert_array_equal(back[1].data, sent[1][3].data)
    assert (back[1].width, back[1].height, back[1].encoding) == (64, 48, 'bgr8')


def test_missing_path(tmp_path: Path) -> None:
    """A path that does not exist is named as such."""
    with pytest.raises(BagError, match=r'nope: no such bag'):
        open_bag(tmp_path / 'nope')


def test_no_metadata(tmp_path: Path) -> None:
    """A directory without metadata.yaml is refused, with the recovery hint when it has a .mcap."""
    bag_path = make_points_bag(tmp_path / 'bag')
    (bag_path / 'metadata.yaml').unlink()
    with pytest.raises(BagError, match=r'no metadata.yaml; an interrupted .* bag-recover'):
        open_bag(bag_path)


def test_truncated_mcap(tmp_path: Path) -> None:
    """A truncated .mcap gives one line naming the file and the fault."""
    bag_path = make_points_bag(tmp_path / 'bag')
    mcap = next(bag_path.glob('*.mcap'))
    mcap.write_bytes(mcap.read_bytes()[:-100])
    with pytest.raises(BagError) as err:
        open_bag(bag_path)
    assert str(mcap) in str(err.value)
    assert 'truncated or corrupt' in str(err.value)
    assert '\n' not in str(err.value)


def test_corrupt_sqlite(tmp_path: Path) -> None:
    """A .db3 overwritten with junk is reported as corrupt, naming the file."""
    bag_path = make_points_bag(tmp_path / 'bag', storage='sqlite3')
    db3 = next(bag_path.glob('*.db3'))
    db3.write_bytes(b'this is not sqlite' * 100)
    with pytest.raises(BagError, match=r'\.db3: truncated or corrupt'), open_bag(bag_path) as bag:
        list(bag.messages())


def test_unknown_type(tmp_path: Path) -> None:
    """A type with no definition in the bag nor installed names the type and the topic."""
    bag_path = tmp_path / 'bag'
    with Writer(bag_path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection('/sim/mystery', 'mystery_msgs/msg/Thing', msgdef='',
                                     rihs01='RIHS01_' + '0' * 64)
        writer.write(conn, START_NS, b'\x00\x01\x00\x00')
    with pytest.raises(BagError, match=r'topic /sim/mystery has unknown message type '
                                       r'mystery_msgs/msg/Thing'):
        open_bag(bag_path)
    with open_bag(bag_path, strict_types=False) as bag:
        assert bag.unknown == {'/sim/mystery': 'mystery_msgs/msg/Thing'}
        assert next(bag.messages()).data == b'\x00\x01\x00\x00'


def test_missing_topic(tmp_path: Path) -> None:
    """Asking for a topic the bag lacks lists the topics it has."""
    bag_path = make_points_bag(tmp_path / 'bag')
    with pytest.raises(BagError, match=r'topic /cam_front/pixel_points not in bag; topics in '
                                       r'the bag: /cam_side/pixel_points'):
        open_bag(bag_path, ['/cam_front/pixel_points'])


def test_write_bag_refuses_existing(tmp_path: Path) -> None:
    """write_bag never overwrites a bag."""
    bag_path = make_points_bag(tmp_path / 'bag')
    with pytest.raises(BagError, match='exists already'):
        make_points_bag(bag_path)
    shutil.rmtree(bag_path)


def test_fast_mcap_reading_agrees_with_rosbags(tmp_path: Path) -> None:
    """The one-read-per-message MCAP path yields exactly what rosbags' own reader yields."""
    store = make_typestore()
    msgs = [*pixel_points(store, 30, camera='cam_side', seed=1),
            *pixel_points(store, 30, camera='cam_front', seed=2),
            *images(store, 30, 320, 240, seed=3)]  # 230 kB frames: several chunks
    bag_path = write_bag(tmp_path / 'bag', sorted(msgs, key=lambda m: m[2]), typestore=store)
    mcap = next(bag_path.glob('*.mcap'))
    assert mcapread.readable(mcap)
    selection = ['/cam_front/pixel_points', '/cam_side/image_raw']
    start = START_NS + 100_000_000
    with open_bag(bag_path) as bag:
        got = [(m.topic, m.log_time_ns, m.data) for m in bag.messages(selection, 0.1)]
    with Reader(bag_path) as reader:
        conns = [c for c in reader.connections if c.topic in selection]
        expected = [(c.topic, t, bytes(d)) for c, t, d in reader.messages(conns, start=start)]
    assert len(got) == 50  # 25 of each topic from 100 ms on
    assert got == expected


def test_compressed_mcap_reads_through_rosbags(tmp_path: Path) -> None:
    """A zstd-chunked bag is not for the fast path but reads all the same."""
    store = make_typestore()
    writer = McapBagWriter(tmp_path / 'bag', compression='zstd')
    writer.open()
    channel = writer.add_topic('/cam_side/pixel_points', 'dempath_msgs/msg/PixelPoints', '')
    sent = [(t, bytes(store.serialize_cdr(m, k))) for _, k, t, m in pixel_points(store, 5)]
    for t_ns, data in sent:
        writer.write(channel, t_ns, data)
    writer.close()
    assert not mcapread.readable(writer.mcap_path)
    with open_bag(tmp_path / 'bag') as bag:
        assert [(m.log_time_ns, m.data) for m in bag.messages()] == sent


def test_type_defined_in_bag_as_idl_is_readable(tmp_path: Path) -> None:
    """A custom type stored as ros2idl (as rosbag2 does for some packages) deserializes too."""
    idl = ('module idl_msgs {\n  module msg {\n    struct Point2 {\n      double x;\n'
           '      double y;\n    };\n  };\n};\n')
    store = make_typestore()
    store.register(get_types_from_idl(idl))
    msg = store.types['idl_msgs/msg/Point2'](x=1.5, y=-2.0)
    bag_path = tmp_path / 'bag'
    with Writer(bag_path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection(
            '/sim/point', 'idl_msgs/msg/Point2',
            msgdef='=' * 80 + '\nIDL: idl_msgs/msg/Point2\n' + idl,
            rihs01=store.hash_rihs01('idl_msgs/msg/Point2'))
        writer.write(conn, START_NS, store.serialize_cdr(msg, 'idl_msgs/msg/Point2'))
    with open_bag(bag_path) as bag:
        back = bag.deserialize(next(bag.messages()))
    assert (back.x, back.y) == (1.5, -2.0)
