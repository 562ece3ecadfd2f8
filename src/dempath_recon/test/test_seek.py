"""Faint spots sought where the other camera gives out a marker this camera holds no track of
(``tracking.seek``), on real JPEG frames of known truth (``spots.py``) and the cameras of a
rendered look (``data/grey_sand_first_frames.json``)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from spots import CLAY, SAND, spot_image

from dempath_calib.camera import CameraModel
from dempath_recon.tracking.associate import MarkerGrid, marker_diameter_px, project
from dempath_recon.tracking.detect import MIN_SUM_DN, SOUGHT_DIM_SUM_DN, Detections, MarkerDetector
from dempath_recon.tracking.seek import bar_sought
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

DATA = Path(__file__).parent / 'data' / 'grey_sand_first_frames.json'
SOUGHT = 8  # the marker drawn 60 % buried in the side camera: under the frame's threshold
T0 = 1700000001.4


def side_frames(seek: bool) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray]:
    """Four frame pairs of 15 markers resting on their grid points at dusk (light x0.35): the
    side camera's JPEG (marker ``SOUGHT`` 60 % buried) and the front camera's exact
    detections, through the two-camera tracker; each side frame's (markers, px) and the side
    camera's true centres (15, 2) px."""
    data = json.loads(DATA.read_text())
    cams = {c['name']: CameraModel.from_dict(c) for c in data['cameras']}
    grid = MarkerGrid(layout_m=tuple(tuple(p) for p in data['marker_grid_m']))
    xyz = np.array(data['marker_grid_m'])
    side_uv, front_uv = project(cams['cam_side'], xyz), project(cams['cam_front'], xyz)
    radius = 0.5 * marker_diameter_px(cams['cam_side'], grid, 0.008)
    buried = np.where(np.arange(1, 16) == SOUGHT, 0.6, 0.0)
    rng = np.random.default_rng(3)
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=grid, seek_other=seek))
    out = []
    for k in range(4):
        jpeg = spot_image((1080, 1920), side_uv, radius, rng, gain=0.35, noise_dn=2.0,
                          buried=buried)
        f = tracker.update('cam_side', T0 + 0.02 * k, jpeg)
        tracker.update_detections('cam_front', T0 + 0.02 * k + 0.003,
                                  Detections(front_uv, np.ones(15), np.full(15, 2.5)))
        out.append((f.markers, f.uv))
    return out, side_uv


def test_a_marker_under_the_threshold_in_one_camera_is_sought_and_numbered() -> None:
    """The side camera's frame misses the buried marker; the front camera gives it out, so
    from the second frame on the side camera finds it on the front's line of sight and the
    pair numbering numbers it (within 3 px of its visible part's middle); no spot is given
    another marker's number."""
    frames, truth = side_frames(seek=True)
    for k, (markers, uv) in enumerate(frames):
        owner = np.linalg.norm(uv[:, None] - truth[None], axis=2).argmin(axis=1) + 1
        assert not ((markers >= 0) & (markers != owner)).any(), f'frame {k}: a wrong number'
        d = np.linalg.norm(uv - truth[SOUGHT - 1], axis=1)
        if k == 0:
            assert d.min() > 8, 'the frame itself found the buried marker: no test'
        else:
            assert d.min() < 3 and markers[d.argmin()] == SOUGHT, f'frame {k}: not numbered'


def test_without_the_search_the_marker_stays_missing() -> None:
    """The rule matters: with ``seek_other`` off the side camera never has it."""
    frames, truth = side_frames(seek=False)
    assert all(np.linalg.norm(uv - truth[SOUGHT - 1], axis=1).min() > 8 for _, uv in frames)


def test_weak_markers_in_dusk_sand_are_found_by_the_window_noise_bar_below_100_dn() -> None:
    """Sand at light x0.2 sums about 80 grey levels (over the chroma's floor of 60, under
    normal light's 105-200) and clay half mixed with sand keeps little chroma: the frame finds
    none, the fixed faint bar none, the window's noise bar (the sought search's brightness
    limit, 100) most of them within 2 px; none in bare sand 20 px away."""
    rng = np.random.default_rng(5)
    gx, gy = np.meshgrid(np.arange(30, 300, 40), np.arange(30, 220, 40))
    truth = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-4, 4, (gx.size, 2))
    jpeg = spot_image((240, 320), truth, 4.2, rng, gain=0.2, noise_dn=3.0, quality=85,
                      clay_bgr=0.5 * CLAY + 0.5 * SAND)
    det = MarkerDetector().detect_jpeg(jpeg)
    assert det.faint is not None and len(det.uv) == 0
    pred = truth + rng.normal(0, 1.0, truth.shape)

    def found(limit: float) -> float:
        assert det.faint is not None
        return float(np.mean(np.linalg.norm(det.faint(pred, 4.0, None, limit) - truth,
                                            axis=1) < 2.0))

    assert found(MIN_SUM_DN) < 0.1
    assert found(SOUGHT_DIM_SUM_DN) > 0.8
    bare = det.faint(truth + np.array([20.0, 0.0]), 4.0, None, SOUGHT_DIM_SUM_DN)
    assert not np.isfinite(bare).all(axis=1).any(), 'a spot found in bare sand'


def test_sought_spots_are_barred_to_every_numbered_track() -> None:
    """A sought spot was sought for a marker this camera holds no track of: no numbered track
    may link to it (a lost one re-attaching would take another marker's spot); unnumbered
    tracks may, and the frame's own spots keep their bars."""
    data = json.loads(DATA.read_text())
    cams = {c['name']: CameraModel.from_dict(c) for c in data['cameras']}
    grid = MarkerGrid(layout_m=tuple(tuple(p) for p in data['marker_grid_m']))
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=grid))
    xyz = np.array(data['marker_grid_m'])
    uv = project(cams['cam_side'], xyz)
    tracker.update_detections('cam_side', T0, Detections(uv, np.ones(15), np.full(15, 2.5)))
    tracks = tracker.state.trackers['cam_side'].tracks
    numbered = [t.track_id for t in tracks if t.marker >= 0]
    assert numbered, 'the grid numbered nothing: no test'
    tracker.state.trackers['cam_side'].tracks[0].marker = -1  # one unnumbered track
    free = tracks[0].track_id
    given = {numbered[-1]: np.array([True] + [False] * 16)}
    out = bar_sought(tracker.state, 'cam_side', given, 15, 17)
    for t in tracks:
        if t.marker >= 0:
            assert out[t.track_id][15:].all(), t.track_id
    assert free not in out
    assert out[numbered[-1]][0] and not out[numbered[-1]][1:15].any()
    assert bar_sought(tracker.state, 'cam_side', given, 15, 15) is given
