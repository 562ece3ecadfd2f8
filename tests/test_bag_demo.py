"""The shipped sample bag ``bags/demo_two_cams`` is intact and readable."""

from __future__ import annotations

from pathlib import Path

from dempath.bagio import open_bag

SAMPLE_BAG = Path(__file__).resolve().parents[1] / 'bags' / 'demo_two_cams'


def test_sample_bag_contents() -> None:
    """The shipped bag holds both cameras' JPEG frames and pixel points, 100 of each."""
    with open_bag(SAMPLE_BAG) as bag:
        counts = {t: i.msgcount for t, i in bag.topics.items()}
    assert counts == {f'/{cam}/{kind}': 100 for cam in ('cam_side', 'cam_front')
                      for kind in ('image_raw/compressed', 'pixel_points')}
