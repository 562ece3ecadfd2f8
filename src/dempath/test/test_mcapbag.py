"""mcapbag: incremental MCAP bags readable by rosbags and mcap-ros2, recovery of cut files."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from dempath.bagio import open_bag
from dempath.errors import BagError, OutputError
from dempath.mcapbag import McapBagWriter, check_output_dir, recover_bag, write_metadata
from dempath.testbags import pixel_points
from dempath.typestore import make_typestore, message_definition

TOPIC, MSGTYPE = '/cam_side/pixel_points', 'dempath_msgs/msg/PixelPoints'


def serialized_points(count: int, seed: int = 0) -> list[tuple[int, bytes]]:
    """(time [ns], CDR bytes) of ``count`` seeded PixelPoints."""
    store = make_typestore()
    return [(t, bytes(store.serialize_cdr(m, MSGTYPE)))
            for _, _, t, m in pixel_points(store, count, seed=seed)]


def write_points(bag_dir: Path, batches: list[list[tuple[int, bytes]]],
                 close: bool = True) -> McapBagWriter:
    """Write each batch, flushing (closing a chunk) after each; close unless asked not to."""
    writer = McapBagWriter(bag_dir)
    writer.open()
    channel = writer.add_topic(TOPIC, MSGTYPE, message_definition(make_typestore(), MSGTYPE))
    for batch in batches:
        for t_ns, data in batch:
            writer.write(channel, t_ns, data)
        writer.flush()
    if close:
        writer.close()
    return writer


def test_written_bag_reads_in_rosbags_and_mcap_ros2(tmp_path: Path) -> None:
    """The same messages come back through rosbags and through mcap-ros2 decoding."""
    sent = serialized_points(6)
    write_points(tmp_path / 'bag', [sent[:3], sent[3:]])
    with open_bag(tmp_path / 'bag') as bag:
        assert [(m.log_time_ns, m.data) for m in bag.messages()] == sent
        assert bag.topics[TOPIC].msgdef.startswith('uint8 SOURCE_DETECTED=0')
    store = make_typestore()
    with (tmp_path / 'bag' / 'bag_0.mcap').open('rb') as stream:
        reader = make_reader(stream, validate_crcs=True, decoder_factories=[DecoderFactory()])
        decoded = [msg for _, _, _, msg in reader.iter_decoded_messages()]
        summary = reader.get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == 6 and len(summary.chunk_indexes) == 2
    expected = store.deserialize_cdr(sent[4][1], MSGTYPE)
    np.testing.assert_array_equal(decoded[4].u, expected.u)
    assert decoded[4].header.frame_id == 'cam_side'


def test_recover_keeps_every_flushed_chunk(tmp_path: Path) -> None:
    """A file cut inside the unflushed tail (as after SIGKILL) keeps all flushed messages."""
    sent = serialized_points(9)
    bag_dir = tmp_path / 'bag'
    writer = write_points(bag_dir, [sent[:4], sent[4:7]], close=False)
    flushed_size = writer.mcap_path.stat().st_size
    for t_ns, data in sent[7:]:
        writer.write(1, t_ns, data)  # in the open chunk, never flushed
    cut = tmp_path / 'cut.mcap'
    shutil.copyfile(writer.mcap_path, cut)
    writer.close()
    shutil.rmtree(bag_dir)
    bag_dir.mkdir()
    with cut.open('rb') as src:
        (bag_dir / 'bag_0.mcap').write_bytes(src.read(flushed_size + 5))  # a torn record too
    with pytest.raises(BagError, match='bag-recover'):
        open_bag(bag_dir)
    report = recover_bag(bag_dir)
    assert report.kept == {'bag_0.mcap': 7}
    assert report.rebuilt == ['bag_0.mcap']
    assert (bag_dir / 'bag_0.mcap.broken').exists()
    with open_bag(bag_dir) as bag:
        assert [(m.log_time_ns, m.data) for m in bag.messages()] == sent[:7]


def test_recover_leaves_intact_bag(tmp_path: Path) -> None:
    """A complete MCAP is kept as it is; only metadata.yaml is rewritten."""
    sent = serialized_points(3)
    write_points(tmp_path / 'bag', [sent])
    (tmp_path / 'bag' / 'metadata.yaml').unlink()
    report = recover_bag(tmp_path / 'bag')
    assert report.kept == {'bag_0.mcap': 3} and report.rebuilt == []
    with open_bag(tmp_path / 'bag') as bag:
        assert bag.message_count == 3


def test_recover_needs_mcap(tmp_path: Path) -> None:
    """A folder without .mcap files cannot be recovered and says so."""
    with pytest.raises(BagError, match=r'no \.mcap files to recover'):
        recover_bag(tmp_path)


def test_metadata_counts(tmp_path: Path) -> None:
    """metadata.yaml counts every message and spans first to last bag time."""
    sent = serialized_points(4)
    write_points(tmp_path / 'bag', [sent])
    info = write_metadata(tmp_path / 'bag')
    assert info['message_count'] == 4
    assert info['duration']['nanoseconds'] == sent[-1][0] - sent[0][0]
    assert info['topics_with_message_count'][0]['message_count'] == 4


def test_output_checks(tmp_path: Path) -> None:
    """An existing bag, or a parent that is a file or not writable, is refused before writing."""
    with pytest.raises(OutputError, match='exists already'):
        check_output_dir(tmp_path)
    blocker = tmp_path / 'a_file'
    blocker.write_text('not a directory')
    with pytest.raises(OutputError, match='a_file is not a writable directory'):
        check_output_dir(blocker / 'bag')
    with pytest.raises(OutputError, match='cannot create the output bag'):
        McapBagWriter('/proc/dempath_test_bag').open()  # even root cannot mkdir in /proc


def test_recover_stops_at_a_damaged_chunk(tmp_path: Path) -> None:
    """A chunk whose CRC does not match ends the recovery; the chunks before it are kept."""
    sent = serialized_points(9)
    bag_dir = tmp_path / 'bag'
    writer = write_points(bag_dir, [sent[:3], sent[3:6], sent[6:]], close=False)
    data = bytearray(writer.mcap_path.read_bytes())
    second = data.index(sent[4][1])  # the raw bytes of a message in the second chunk
    data[second + 40] ^= 0xFF
    writer.close()
    (bag_dir / 'metadata.yaml').unlink()
    writer.mcap_path.write_bytes(bytes(data))  # as a killed recorder with bad disk would leave
    report = recover_bag(bag_dir)
    assert report.kept == {'bag_0.mcap': 3}
    assert 'crc validation failed' in report.stopped_at['bag_0.mcap']
    with open_bag(bag_dir) as bag:
        assert [(m.log_time_ns, m.data) for m in bag.messages()] == sent[:3]
