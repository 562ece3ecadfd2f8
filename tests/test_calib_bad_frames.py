"""Calibration from a bag with a damaged JPEG in the middle: the frame is named (topic, index,
stamp), counted and skipped, and the calibration goes on (it used to abort with "cannot decode
compressed image" naming no frame)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from dempath.bagio import open_bag
from dempath.typestore import make_typestore
from dempath_calib.cli import calibrate_main
from dempath_calib.errors import InputSourceError
from dempath_calib.sources import BagSource

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / 'bags' / 'calib_twin_small'
FRONT = '/cam_front/image_raw/compressed'


def damaged_copy(src: Path, dst: Path, damage: Any) -> Path:
    """A copy of ``src`` where ``damage(topic, index)`` says which images to cut short."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = make_typestore()
    index: dict[str, int] = {}
    with open_bag(src) as reader, Writer(dst, version=9,
                                         storage_plugin=StoragePlugin.MCAP) as writer:
        conns: dict[str, Any] = {}
        for raw in reader.messages(list(reader.topics)):
            data = bytes(raw.data)
            k = index[raw.topic] = index.get(raw.topic, -1) + 1
            if raw.msgtype.endswith('CompressedImage') and damage(raw.topic, k):
                msg = reader.deserialize(raw)
                msg.data = msg.data[:400]
                data = bytes(store.serialize_cdr(msg, raw.msgtype))
            if raw.topic not in conns:
                conns[raw.topic] = writer.add_connection(raw.topic, raw.msgtype, typestore=store)
            writer.write(conns[raw.topic], raw.log_time_ns, data)
    return dst


def test_damaged_frame_is_named_counted_and_skipped(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str],
                                                    caplog: pytest.LogCaptureFixture) -> None:
    """One cut-short JPEG of the front camera: exit 0, the warning names topic, index and
    stamp, the summary counts 1 undecodable image."""
    bag = damaged_copy(SHIPPED, tmp_path / 'bag', lambda topic, k: topic == FRONT and k == 7)
    code = calibrate_main([str(bag), '--out', str(tmp_path / 'out')])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert json.loads(out.strip().splitlines()[-1])['undecodable_images'] == 1
    lines = [r.getMessage() for r in caplog.records if 'skipped' in r.getMessage()]
    assert len(lines) == 1 and f'{FRONT} image 7 at ' in lines[0], lines


def test_bag_without_any_decodable_image_is_one_error(tmp_path: Path) -> None:
    """Every image damaged: one error naming the bag and the first damaged frame."""
    bag = damaged_copy(SHIPPED, tmp_path / 'bag', lambda topic, k: True)
    with pytest.raises(InputSourceError, match=r'none of its 40 images can be decoded'):
        list(BagSource(bag).frames())
