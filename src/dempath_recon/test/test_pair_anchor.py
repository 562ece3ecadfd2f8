"""One camera's grid numbers placed by the spots both cameras numbered (``tracking.pair_anchor``),
on the detections of a rendered look's first frames (grey sand, light blue clay, JPEG 70)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from dempath_calib.camera import CameraModel
from dempath_recon.tracking.associate import MarkerGrid, number_by_grid
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.pair_anchor import pair_shift, vote_contradicted
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

DATA = Path(__file__).parent / 'data' / 'grey_sand_first_frames.json'


def look() -> dict[str, Any]:
    """The render's cameras, grid and first frame of each camera (detections and truth)."""
    out: dict[str, Any] = json.loads(DATA.read_text())
    return out


def owner(frame: dict[str, Any], ids: list[int]) -> np.ndarray:
    """(n,) the marker whose true centre lies within 3 px of each detection (-1: none)."""
    uv, true = np.array(frame['uv']), np.array(frame['true_uv'])
    d = np.linalg.norm(uv[:, None] - true[None], axis=2)
    return np.where(d.min(axis=1) < 3.0, np.array(ids)[d.argmin(axis=1)], -1)


def test_the_vote_slips_a_row_and_the_pairs_put_it_back() -> None:
    """The front camera's own grid vote, a third of its markers missing, fits one row over
    (the spots of markers 1 and 2 take 2 and 3); shifted by where its spots numbered with the
    side camera sit (their true numbers here), no spot it numbers is another marker."""
    data = look()
    cam = CameraModel.from_dict(next(c for c in data['cameras'] if c['name'] == 'cam_front'))
    grid = MarkerGrid(layout_m=tuple(tuple(p) for p in data['marker_grid_m']))
    frame = next(f for f in data['frames'] if f['camera'] == 'cam_front')
    uv, truth = np.array(frame['uv']), owner(frame, data['marker_ids'])
    voted, _ = number_by_grid(cam, uv, grid)
    assert ((voted >= 0) & (voted != truth)).sum() >= 2  # the cause, as rendered
    paired = np.where(np.isin(truth, [4, 6, 9, 10, 11, 13, 14]), truth, -1).astype(np.int32)
    assert vote_contradicted(voted, paired)  # the pairs' spots it numbers, it numbers off
    assert not vote_contradicted(np.where(paired >= 0, paired, voted), paired)
    shift = pair_shift(cam, uv, paired, grid)
    assert shift is not None
    anchored, _ = number_by_grid(cam, uv, grid, shift_px=shift)
    assert (anchored >= 0).sum() >= 4
    assert not ((anchored >= 0) & (anchored != truth)).any()
    assert pair_shift(cam, uv, np.where(truth == 4, 4, -1).astype(np.int32), grid) is None


def test_the_tracker_numbers_the_front_camera_own_markers_at_the_first_fit() -> None:
    """Both first frames through the two-camera tracker: the front camera's spots of markers 1
    and 2 (seen by it alone: its grid numbers them) are not given their neighbours' numbers."""
    data = look()
    cams = {c['name']: CameraModel.from_dict(c) for c in data['cameras']}
    grid = MarkerGrid(layout_m=tuple(tuple(p) for p in data['marker_grid_m']))
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=grid))
    for frame in data['frames']:
        tracker.update_detections(frame['camera'], frame['stamp_s'], Detections(
            np.array(frame['uv']), np.array(frame['confidence']), np.array(frame['size_px'])))
    front = next(f for f in data['frames'] if f['camera'] == 'cam_front')
    truth = owner(front, data['marker_ids'])
    tracks = tracker.state.trackers['cam_front'].tracks
    got = {}
    for t in tracks:
        d = np.linalg.norm(np.array(front['uv']) - np.asarray(t.uv), axis=1)
        got[int(truth[int(d.argmin())])] = t.marker
    wrong = {m: g for m, g in got.items() if g >= 0 and g != m}
    assert not wrong, wrong
