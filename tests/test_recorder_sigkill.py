"""A real recorder process: SIGKILL keeps each flushed chunk (via bag-recover), SIGINT closes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.exceptions import McapError
from mcap.records import Message
from mcap.stream_reader import StreamReader

from dempath.bagio import open_bag
from dempath.cli import main as dempath
from dempath.errors import BagError
from dempath.nodes.harness import RosHarness
from dempath.nodes.msgtypes import reliable_qos
from dempath.testbags import pixel_points
from dempath.typestore import make_typestore
from dempath_msgs.msg import PixelPoints

TOPIC = '/cam_side/pixel_points'


def start_recorder(harness: RosHarness, output: Path) -> subprocess.Popen[str]:
    """``dempath record`` in its own process, on the harness's ROS domain, flushing every 0.2 s."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(harness.domain_id),
               ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    return subprocess.Popen(
        [sys.executable, '-m', 'dempath.cli', 'record', '-o', str(output), TOPIC,
         '--flush-period', '0.2'], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True)


def readable_messages(mcap: Path) -> int:
    """Messages a streaming reader gets from the file as it is now (stops at a torn record)."""
    count = 0
    if not mcap.exists():
        return 0
    with mcap.open('rb') as stream:
        try:
            for record in StreamReader(stream, emit_chunks=False).records:
                count += isinstance(record, Message)
        except (McapError, EOFError, ValueError):
            pass
    return count


def same_cdr(got: list[bytes], sent: list[bytes]) -> bool:
    """Byte-identical up to the CDR end padding (< 4 zero bytes) that DDS adds across processes."""
    return len(got) == len(sent) and all(
        g.startswith(s) and len(g) - len(s) < 4 and not g[len(s):].strip(b'\x00')
        for g, s in zip(got, sent, strict=True))


def publish_points(harness: RosHarness, count: int, seed: int) -> list[bytes]:
    """Publish ``count`` PixelPoints as raw CDR to the recorder process; return the bytes.

    The publisher is transient local (so the recorder subscribes transient local too): DDS
    matches a pair from each side separately, and a volatile reader that has not yet matched
    the writer when it publishes drops what was sent before (Fast DDS issue 2641); a fresh-clone
    CI once lost 25 of 30 messages that way. Kept history makes the test independent of which
    side matches first.
    """
    store = make_typestore()
    payloads = [bytes(store.serialize_cdr(m, t)) for _, t, _, m in
                pixel_points(store, count, seed=seed)]
    pub = harness.publisher(PixelPoints, TOPIC, reliable_qos(100, latched=True))
    assert harness.wait_for_subscribers(pub, timeout_s=30), 'recorder process not discovered'
    harness.publish_all(pub, payloads)
    return payloads


def test_sigkill_then_recover_keeps_flushed_messages(tmp_path: Path,
                                                      ros_harness: RosHarness) -> None:
    """After SIGKILL the bag is refused; bag-recover restores every message flushed before."""
    output = tmp_path / 'rec'
    proc = start_recorder(ros_harness, output)
    try:
        sent = publish_points(ros_harness, 30, seed=4)
        mcap = output / 'rec_0.mcap'
        deadline = time.monotonic() + 20
        while readable_messages(mcap) < 30 and time.monotonic() < deadline:
            ros_harness.spin_for(0.1)
        assert readable_messages(mcap) == 30, 'messages never reached the disk'
    finally:
        proc.kill()
        proc.communicate(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    assert not (output / 'metadata.yaml').exists()
    with pytest.raises(BagError, match='bag-recover'):
        open_bag(output)
    assert dempath(['bag-recover', str(output)]) == 0
    with open_bag(output) as bag:
        assert same_cdr([m.data for m in bag.messages()], sent)
    assert (output / 'rec_0.mcap.broken').exists()


def test_sigint_finalises_the_bag(tmp_path: Path, ros_harness: RosHarness) -> None:
    """SIGINT closes the bag with metadata.yaml and prints the counts, nothing dropped."""
    output = tmp_path / 'rec'
    proc = start_recorder(ros_harness, output)
    try:
        sent = publish_points(ros_harness, 20, seed=5)
        deadline = time.monotonic() + 20
        while readable_messages(output / 'rec_0.mcap') < 20 and time.monotonic() < deadline:
            ros_harness.spin_for(0.1)
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert 'total: received 20, written 20, dropped 0, late ' in err  # late: load-dependent
    with open_bag(output) as bag:
        assert same_cdr([m.data for m in bag.messages()], sent)
