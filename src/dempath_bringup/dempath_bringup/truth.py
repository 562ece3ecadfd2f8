"""Checks of the demo's outputs against a synthetic recording's truth file (never an input).

A rendered recording keeps its truth beside the bag (``<bag>.truth.json``: per camera frame the
stamp, each marker's pixel centre, visibility and 3D position in the field frame). The product
never reads it; the demo and ``bench/demo.py`` use it to say how far the reconstruction is off.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath.errors import DempathError

MATCH_S = 0.005  # a 3D frame belongs to the side camera's truth frame this close [s]


def truth_frames(truth_json: Path, camera: str | None = None) -> tuple[list[Any], dict[str, Any]]:
    """The truth's frames (of one camera, or all) and the whole record."""
    data = json.loads(truth_json.read_text())
    frames = [f for f in data['frames'] if camera is None or f['camera'] == camera]
    return frames, data


def render_truth_error(bag: Path, truth_json: Path) -> tuple[float, float, float]:
    """(mean, max, RMS) mm of the bag's MarkerPoints3D from the true 3D markers."""
    err_mm = render_truth_errors(bag, truth_json)
    return (float(np.nanmean(err_mm)), float(np.nanmax(err_mm)),
            float(np.sqrt(np.nanmean(err_mm ** 2))))


def points_at_truth_frames(bag: Path, data: dict[str, Any]) -> Iterator[tuple[int, Any]]:
    """(side truth frame index, MarkerPoints3D message) of every 3D frame of the bag within
    ``MATCH_S`` of a side camera's truth frame (the nearest in stamp)."""
    from dempath import topics
    from dempath.bagio import open_bag

    side = data['cameras'][0]['name']
    stamps = np.array([f['stamp_ns'] for f in data['frames'] if f['camera'] == side], np.int64)
    if not len(stamps):
        return
    with open_bag(bag, [topics.MARKER_POINTS]) as reader:
        for raw in reader.messages([topics.MARKER_POINTS]):
            msg = reader.deserialize(raw)
            t_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            k = int(np.argmin(np.abs(stamps - t_ns)))
            if abs(int(stamps[k]) - t_ns) <= MATCH_S * 1e9:
                yield k, msg


def surface_coverage(bag: Path, truth_json: Path, share: float = 0.8) -> tuple[int, int] | None:
    """(markers reconstructed, markers): markers with a 3D point in the bag in at least
    ``share`` of the frames in which the recording's truth has them on the surface (a marker
    buried by the heave cannot be seen by any camera); None when the truth does not say.
    """
    data = json.loads(truth_json.read_text())
    if 'on_surface' not in data:
        return None
    up = np.asarray(data['on_surface'], bool)
    column = {int(m): j for j, m in enumerate(data['marker_ids'])}
    seen = np.zeros_like(up)
    for k, msg in points_at_truth_frames(bag, data):
        for m in msg.marker_ids:
            if int(m) in column and k < len(up):
                seen[k, column[int(m)]] = True
    shares = (seen & up).sum(0) / np.maximum(up.sum(0), 1)
    return int((shares >= share).sum()), len(column)


def render_truth_errors(bag: Path, truth_json: Path) -> NDArray[np.float64]:
    """Distance [mm] of every 3D marker point of the bag from its true position, (n,).

    Each 3D frame is matched to the side camera's truth frame nearest in stamp (within
    ``MATCH_S``); markers are matched by number.

    Raises:
        DempathError: no 3D frame matches a truth frame.
    """
    data = json.loads(truth_json.read_text())
    side = data['cameras'][0]['name']
    frames = [f for f in data['frames'] if f['camera'] == side]
    column = {int(m): j for j, m in enumerate(data['marker_ids'])}
    errors = []
    for k, msg in points_at_truth_frames(bag, data):
        ref = np.asarray(frames[k]['xyz'], np.float64)
        for m, x, y, z in zip(msg.marker_ids, msg.x, msg.y, msg.z, strict=True):
            if int(m) in column and np.isfinite(ref[column[int(m)]]).all():
                errors.append(np.linalg.norm(np.array([x, y, z]) - ref[column[int(m)]]))
    if not errors:
        msg = f'{bag}: no MarkerPoints3D at the stamps of {truth_json}'
        raise DempathError(msg)
    return 1e3 * np.asarray(errors, np.float64)
