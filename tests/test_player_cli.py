"""``dempath play`` and ``dempath bag-info`` on good bags: exit 0 and the counts."""

from __future__ import annotations

from pathlib import Path

import pytest

from dempath.bagio import write_bag
from dempath.cli import main as dempath
from dempath.nodes.harness import unique_domain_id
from dempath.testbags import pixel_points
from dempath.typestore import make_typestore


@pytest.fixture
def bag(tmp_path: Path) -> Path:
    """Two cameras' PixelPoints, 6 each."""
    store = make_typestore()
    msgs = [*pixel_points(store, 6, camera='cam_side'),
            *pixel_points(store, 6, camera='cam_front')]
    return write_bag(tmp_path / 'bag', sorted(msgs, key=lambda m: m[2]), typestore=store)


def test_play_selected_topic(bag: Path, monkeypatch: pytest.MonkeyPatch,
                             capsys: pytest.CaptureFixture[str]) -> None:
    """Playing one topic from an offset publishes just those messages and exits 0."""
    monkeypatch.setenv('ROS_DOMAIN_ID', str(unique_domain_id()))
    argv = ['play', str(bag), '--rate', '0', '--start-offset', '0.04',
            '--topics', '/cam_front/pixel_points']
    assert dempath(argv) == 0
    assert f'{bag}: published 4 messages' in capsys.readouterr().out


def test_bag_info(bag: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """bag-info lists each topic with its type and count and the time span."""
    assert dempath(['bag-info', str(bag)]) == 0
    out = capsys.readouterr().out
    assert 'duration: 0.100 s' in out and 'messages: 12' in out
    assert '/cam_side/pixel_points' in out and 'dempath_msgs/msg/PixelPoints' in out
