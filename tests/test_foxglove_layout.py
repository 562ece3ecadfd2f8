"""docs/foxglove_layout.json names only topics the demo graph records and frames in its bags."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from dempath.frames import FIELD, SCENE, TOOL, WORLD, optical_frame
from dempath.topics import CAMERAS
from dempath_bringup.nodes.graph import graph_topics

LAYOUT = Path(__file__).resolve().parents[1] / 'docs' / 'foxglove_layout.json'


def leaves(tree: Any) -> list[str]:
    """Panel ids of a Foxglove layout tree."""
    if isinstance(tree, str):
        return [tree]
    return leaves(tree['first']) + leaves(tree['second'])


def test_layout_matches_the_recorded_topics_and_frames() -> None:
    """Panels exist; their topics are recorded; their frames are in the TF tree."""
    layout = json.loads(LAYOUT.read_text())
    panels = layout['configById']
    assert sorted(leaves(layout['layout'])) == sorted(panels)
    recorded = set(graph_topics())
    frames = {WORLD, SCENE, FIELD, TOOL} | {optical_frame(c) for c in CAMERAS}
    named: set[str] = set()
    for config in panels.values():
        named |= set(config.get('topics', {}))
        image = config.get('imageMode', {})
        named |= {image[k] for k in ('imageTopic', 'calibrationTopic') if k in image}
        named |= {p['value'].split('.')[0] for p in config.get('paths', [])}
        named |= {config['topicPath']} if 'topicPath' in config else set()
        for key in config.get('transforms', {}):
            assert key.removeprefix('frame:') in frames, key
        assert config.get('followTf', WORLD) in frames
    assert named and named <= recorded, sorted(named - recorded)
