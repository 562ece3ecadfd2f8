"""The field frames of a rendered recording (after its board segment), read once for the tests
that feed detectors, trackers or nodes with them."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from dempath import topics
from dempath.bagio import RawMessage, open_bag


def stamp_ns(msg: Any) -> int:
    """A message's header stamp [ns]."""
    return int(msg.header.stamp.sec) * 10**9 + int(msg.header.stamp.nanosec)


def field_images(render: Path, per_camera: int | None = None,
                 ) -> Iterator[tuple[str, RawMessage, Any]]:
    """(camera, serialized message, CompressedImage) of the render's field frames in bag order,
    from the truth's ``field_start_ns`` on; with ``per_camera``, only each camera's first ones."""
    truth = json.loads(render.with_name(render.name + '.truth.json').read_text())
    start_ns = int(truth['calibration_segment']['field_start_ns'])
    topic_cam = {topics.camera_topic(topics.IMAGE_COMPRESSED, c): c for c in topics.CAMERAS}
    seen = dict.fromkeys(topics.CAMERAS, 0)
    with open_bag(render, list(topic_cam)) as reader:
        for raw in reader.messages(list(topic_cam)):
            msg = reader.deserialize(raw)
            cam = topic_cam[raw.topic]
            if stamp_ns(msg) >= start_ns and (per_camera is None or seen[cam] < per_camera):
                seen[cam] += 1
                yield cam, raw, msg
