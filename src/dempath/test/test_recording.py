"""recording: every message is written or counted; the bag is complete after close."""

from __future__ import annotations

from pathlib import Path

import pytest

from dempath.bagio import open_bag
from dempath.errors import OutputError
from dempath.recording import BagRecorder, RecorderConfig

TOPIC, MSGTYPE = '/sim/tool_force', 'dempath_msgs/msg/ToolForce'


def open_recorder(tmp_path: Path, **overrides: object) -> BagRecorder:
    """A started recorder on ``tmp_path/bag`` with one ToolForce topic."""
    recorder = BagRecorder(RecorderConfig(output=str(tmp_path / 'bag'), **overrides))
    recorder.open()
    recorder.add_topic(TOPIC, MSGTYPE)
    return recorder


def payload(i: int) -> bytes:
    """A distinct fake CDR payload (the recorder never decodes)."""
    return b'\x00\x01\x00\x00' + i.to_bytes(4, 'little') * 8


def test_all_written_in_order(tmp_path: Path) -> None:
    """Submitted messages are all written, with their times, and counted as such."""
    recorder = open_recorder(tmp_path)
    for i in range(50):
        assert recorder.submit(TOPIC, payload(i), 1_000 + i, 900 + i, sequence=i + 1)
    stats = recorder.close()[TOPIC]
    assert (stats.received, stats.written, stats.dropped, stats.late) == (50, 50, 0, 0)
    with open_bag(tmp_path / 'bag') as bag:
        got = [(m.log_time_ns, m.data) for m in bag.messages()]
    assert got == [(1_000 + i, payload(i)) for i in range(50)]


def test_summary_names_topics_never_seen(tmp_path: Path) -> None:
    """A requested topic that never appeared is named in the summary, not silently absent."""
    recorder = open_recorder(tmp_path, topics=(TOPIC, '/sim/run_events'))
    recorder.submit(TOPIC, payload(1), 10)
    recorder.close()
    assert recorder.summary().splitlines()[-1] == 'never seen (nothing recorded): /sim/run_events'


def test_sequence_gaps_and_late_are_counted(tmp_path: Path) -> None:
    """A gap in the publisher's sequence counts as dropped; a slow delivery counts as late."""
    recorder = open_recorder(tmp_path, late_threshold_s=0.5)
    recorder.submit(TOPIC, payload(1), 10, sequence=1)
    recorder.submit(TOPIC, payload(2), 20, sequence=4, latency_ns=600_000_000)
    recorder.count_lost(TOPIC, 2)
    stats = recorder.close()[TOPIC]
    assert (stats.received, stats.written, stats.dropped, stats.late) == (2, 2, 4, 1)
    assert 'total: received 2, written 2, dropped 4, late 1' in recorder.summary()


def test_over_budget_is_dropped_and_counted(tmp_path: Path) -> None:
    """A message larger than the writer's byte budget is refused and counted; later ones pass."""
    recorder = open_recorder(tmp_path, max_queue_bytes=1 << 20)
    assert not recorder.submit(TOPIC, b'\x00\x01\x00\x00' + bytes(2 << 20), 1)
    assert recorder.submit(TOPIC, payload(2), 2)
    stats = recorder.close()[TOPIC]
    assert (stats.received, stats.written, stats.dropped) == (2, 1, 1)
    with open_bag(tmp_path / 'bag') as bag:
        assert [m.data for m in bag.messages()] == [payload(2)]


def test_unwritable_output(tmp_path: Path) -> None:
    """An output under a regular file is refused with the path in the message."""
    (tmp_path / 'file').write_text('x')
    recorder = BagRecorder(RecorderConfig(output=str(tmp_path / 'file' / 'bag')))
    with pytest.raises(OutputError, match=r'file/bag: cannot create the output bag'):
        recorder.open()


@pytest.mark.parametrize('field, value', [('output', ''), ('flush_period_s', 0.0),
                                          ('compression', 'rar'), ('chunk_size_bytes', 10)])
def test_config_validation(field: str, value: object) -> None:
    """Bad settings name the field and the value."""
    params = {'output': 'x', field: value}
    with pytest.raises(ValueError, match=field):
        RecorderConfig(**params)  # type: ignore[arg-type]


def test_default_topics_are_dempath_namespaces() -> None:
    """Without a topic list the recorder wants dempath topics and not others."""
    config = RecorderConfig(output='x')
    assert config.wants('/cam_side/pixel_points') and config.wants('/sim/particle_states')
    assert not config.wants('/clock') and not config.wants('/rosout')
    assert RecorderConfig(output='x', topics=('/clock',)).wants('/clock')
