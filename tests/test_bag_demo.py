"""``dempath demo`` on the shipped demo bag: everything played is recorded, missing steps named."""

from __future__ import annotations

from pathlib import Path

import pytest
from dempath.bagio import open_bag
from dempath.cli import main as dempath
from dempath.demo import DEMO_BAG, STEPS


def test_demo_bag_contents() -> None:
    """The shipped bag holds both cameras' JPEG frames and pixel points, 100 of each."""
    with open_bag(DEMO_BAG) as bag:
        counts = {t: i.msgcount for t, i in bag.topics.items()}
    assert counts == {f'/{cam}/{kind}': 100 for cam in ('cam_side', 'cam_front')
                      for kind in ('image_raw/compressed', 'pixel_points')}


def test_demo_records_everything(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The demo's replay step records all 400 messages and the later steps say 'not there yet'."""
    assert dempath(['demo', '--out', str(tmp_path), '--rate', '0']) == 0
    out = capsys.readouterr().out
    assert 'total: received 400, written 400, dropped 0, late ' in out  # late: load-dependent
    missing = [s.name for s in STEPS if s.run is None]
    assert f'not there yet: {", ".join(missing)}' in out
    with open_bag(tmp_path / 'recorded') as recorded, open_bag(DEMO_BAG) as source:
        for topic in source.topics:
            assert [m.data for m in recorded.messages([topic])] == \
                [m.data for m in source.messages([topic])], topic
