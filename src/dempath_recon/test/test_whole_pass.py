"""Numbering from the whole pass (``tracking.whole_pass``): tracks no frame-by-frame rule
numbered, decided at the end of the pass by one assignment over all their frames.

Scenes are the 15-marker grid moved by a slow bed flow and projected through the twin's true
cameras, each camera's points given out as a frame-by-frame pipeline might have left them (a
track unnumbered from its first frame to its last), so each point's marker is known.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from projected import DT, GRID15, OFFSET, feed_frame

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig
from dempath_recon.tracking.whole_pass import number_whole_pass, smooth_pieces

FLOW = np.array([0.0, 0.0004, 0.0008])  # the bed's slow heave and travel [m/frame]
FRAMES = 20
EPIPOLAR_PX = 4.0
FPS = 1 / DT


def _frames(rig, pts: list[dict[int, np.ndarray]], numbered: dict[str, callable],
            ids: dict[str, callable]) -> tuple[list[PixelFrame], list[np.ndarray]]:
    """Both cameras' frames of the pass: ``pts[k]`` marker -> (3,) m at frame ``k`` (a camera
    sees the markers its ``numbered``/``ids`` functions are given), ``numbered[cam](k, m)`` the
    number it gave (-1 none), ``ids[cam](k, m)`` the track id; in stamp order."""
    frames, track_ids = [], []
    for k, at in enumerate(pts):
        for cam, dt in (('cam_side', 0.0), ('cam_front', OFFSET)):
            model = next(c for c in rig.cameras if c.name == cam)
            seen = [m for m in at if ids[cam](k, m) is not None]
            uv = model.project(np.array([at[m] for m in seen]))
            frames.append(PixelFrame(cam, k * DT + dt,
                                     np.array([numbered[cam](k, m) for m in seen], np.int32),
                                     uv, np.ones(len(seen)), ()))
            track_ids.append(np.array([ids[cam](k, m) for m in seen], np.int64))
    return frames, track_ids


def _grid(k: int) -> dict[int, np.ndarray]:
    """The 15 markers at frame ``k`` [m]."""
    return {m: np.array(p) + k * FLOW for m, p in enumerate(GRID15, 1)}


def _given(frames: list[PixelFrame], track_ids: list[np.ndarray], cam: str, track: int,
           ) -> set[int]:
    """The numbers ``cam``'s points of ``track`` were given out with, but its first and last
    (the other camera's point at that instant may lie outside its frames: an unchecked pair
    keeps its point unnumbered)."""
    got = [int(m) for f, t in zip(frames, track_ids, strict=True) if f.camera == cam
           for m in f.markers[t == track]]
    return set(got[1:-1])


def _cameras(rig) -> dict:
    return {c.name: c for c in rig.cameras}


@pytest.mark.parametrize('whole_pass', [False, True])
def test_a_track_one_camera_never_numbered_takes_the_marker_the_other_gives(
        rig, whole_pass: bool) -> None:
    """The front leaves its track of 8 unnumbered all pass while the side gives 8 out: over
    the pass the track stays on 8's epipolar line and nothing else fits it, so it is 8."""
    numbered = {'cam_side': lambda k, m: m, 'cam_front': lambda k, m: -1 if m == 8 else m}
    ids = {'cam_side': lambda k, m: m, 'cam_front': lambda k, m: 100 + m}
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)], numbered, ids)
    if whole_pass:
        frames, given = number_whole_pass(frames, track_ids, _cameras(rig), {}, EPIPOLAR_PX,
                                          FPS)
        assert given == FRAMES - 1  # the front's last frame is after the side's last
    assert _given(frames, track_ids, 'cam_front', 108) == ({8} if whole_pass else {-1})


def _behind_eight(rig, k: int, drift_m: float) -> np.ndarray:
    """A marker (16) on the front's line of sight through 8, 30 mm farther, drifting
    ``drift_m`` per frame sideways (X) from it."""
    front = next(c for c in rig.cameras if c.name == 'cam_front')
    eight = _grid(k)[8]
    centre = -np.asarray(front.R).T @ np.asarray(front.t).ravel()
    ray = (eight - centre) / np.linalg.norm(eight - centre)
    return eight + 0.03 * ray + np.array([drift_m * k, 0.0, 0.0])


@pytest.mark.parametrize(('drift_m', 'expected'), [(0.0, {-1}), (0.001, {8})])
def test_two_markers_on_one_line_leave_the_track_unnumbered_unless_the_pass_parts_them(
        rig, drift_m: float, expected: set[int]) -> None:
    """A marker the side numbers 16 lies on the front's line of sight through 8, hidden
    behind it in the front. When it stays there all pass both 8 and 16 fit the front's track
    equally: it is refused (a close second; fails with ``MARGIN_RATIO`` at 0). When 16
    drifts 1 mm a frame away, the pass tells them apart and the track is 8."""
    pts = []
    for k in range(FRAMES):
        at = _grid(k)
        at[16] = _behind_eight(rig, k, drift_m)
        pts.append(at)
    numbered = {'cam_side': lambda k, m: m, 'cam_front': lambda k, m: -1 if m == 8 else m}
    ids = {'cam_side': lambda k, m: m,
           'cam_front': lambda k, m: None if m == 16 else 100 + m}
    frames, track_ids = _frames(rig, pts, numbered, ids)
    frames, _ = number_whole_pass(frames, track_ids, _cameras(rig), {}, EPIPOLAR_PX, FPS)
    assert _given(frames, track_ids, 'cam_front', 108) == expected


@pytest.mark.parametrize(('offset_m', 'expected'), [(0.0, {8}), (0.04, {-1})])
def test_a_marker_back_in_both_cameras_unnumbered_takes_the_number_whose_path_it_continues(
        rig, offset_m: float, expected: set[int]) -> None:
    """Marker 8, numbered in both cameras for 10 frames, comes back as a new track in each,
    unnumbered in both: the pair of new tracks continues 8's path, so both are 8. A pair 40
    mm off where 8's path leads (a marker cannot jump) is not given 8."""
    pts = [_grid(k) for k in range(FRAMES)]
    for k in range(10, FRAMES):
        pts[k][8] = pts[k][8] + np.array([offset_m, 0.0, 0.0])
    back = {'cam_side': 200, 'cam_front': 300}

    def numbered(cam: str):
        return lambda k, m: -1 if (m == 8 and k >= 10) else m

    def ids(cam: str):
        return lambda k, m: back[cam] if (m == 8 and k >= 10) else m

    frames, track_ids = _frames(rig, pts, {c: numbered(c) for c in back},
                                {c: ids(c) for c in back})
    frames, _ = number_whole_pass(frames, track_ids, _cameras(rig), {}, EPIPOLAR_PX, FPS)
    assert _given(frames, track_ids, 'cam_side', 200) == expected
    assert _given(frames, track_ids, 'cam_front', 300) == expected


def test_a_track_is_cut_where_a_link_jumps_or_comes_back() -> None:
    """A track moving 3 px a frame that jumps 20 px onto a neighbour is two pieces, and so is
    one that comes back after two frames unseen; a smooth one stays whole."""
    times = np.arange(8) * DT
    uv = np.column_stack([100 + 3.0 * np.arange(8), np.full(8, 50.0)])
    assert [len(p) for p in smooth_pieces(times, uv, FPS)] == [8]
    assert [p.tolist() for p in smooth_pieces(np.r_[times[:5], times[5:] + 2 * DT], uv,
                                              FPS)] == [[0, 1, 2, 3, 4], [5, 6, 7]]
    uv[5:, 1] += 20.0
    assert [p.tolist() for p in smooth_pieces(times, uv, FPS)] == [[0, 1, 2, 3, 4],
                                                                   [5, 6, 7]]


def test_a_track_re_attached_after_a_gap_is_numbered_only_before_it(rig) -> None:
    """The front's never-numbered track of 8 is unseen for three frames mid-pass (lost and
    re-attached): the piece before the gap takes 8, the re-attached piece (which may be a
    neighbour's or an off-centre spot) stays unnumbered."""
    numbered = {'cam_side': lambda k, m: m, 'cam_front': lambda k, m: -1 if m == 8 else m}
    ids = {'cam_side': lambda k, m: m,
           'cam_front': lambda k, m: None if (m == 8 and 8 <= k < 11) else 100 + m}
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)], numbered, ids)
    frames, _ = number_whole_pass(frames, track_ids, _cameras(rig), {}, EPIPOLAR_PX, FPS)
    got = [int(m) for f, t in zip(frames, track_ids, strict=True) if f.camera == 'cam_front'
           for m in f.markers[t == 108]]
    assert got == [8] * 8 + [-1] * (FRAMES - 11)


def test_the_tracker_gives_the_whole_pass_out_at_the_end_with_the_same_numbers(rig) -> None:
    """With ``whole_pass`` no frame goes out before ``flush``, then every frame does, in
    arrival order; with nothing left unnumbered the numbers are those given without it."""
    outs = {}
    for on in (False, True):
        cams = _cameras(rig)
        config = replace(StereoTrackConfig(grid=MarkerGrid(layout_m=GRID15)), whole_pass=on)
        tracker = StereoMarkerTracker(cams, config)
        early = []
        for k in range(FRAMES):
            pts = list(_grid(k).values())
            early += feed_frame(tracker, cams, k, pts, pts)
        outs[on] = early + tracker.flush()
        assert (not early) == on
    assert [(f.camera, f.stamp_s) for f in outs[True]] == \
        [(f.camera, f.stamp_s) for f in outs[False]]
    for a, b in zip(outs[False], outs[True], strict=True):
        assert a.markers.tolist() == b.markers.tolist()
    assert sum((f.markers > 0).sum() for f in outs[True]) > 0.9 * 15 * 2 * FRAMES
