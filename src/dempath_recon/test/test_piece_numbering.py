"""Numbering by pieces over the whole pass (``tracking.piece_numbering``): unnumbered stretches
of 2D tracks numbered by how well they continue a marker's path.

The scenes are ``test_joint_fill``'s: the 15-marker grid moved by a slow bed flow, projected
through the twin's true cameras, each camera's points given out as a frame-by-frame pipeline
might have left them (one 2D track per marker and camera, id 100 + marker).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from projected import DT, GRID15
from test_joint_fill import EPIPOLAR_PX, FPS, FRAMES, _frames, _grid, _numbers

from dempath_recon.tracking.piece_numbering import number_pieces, unnumbered_pieces
from dempath_recon.tracking.records import PixelFrame

DIAMETER_PX = 8.0  # a marker's diameter in both images [px]
GAP = range(8, 11)  # the frames where the rules left marker 8 unnumbered


def _run(rig, frames, track_ids) -> tuple[list[PixelFrame], int]:
    """:func:`number_pieces` with the rig's cameras and grid at the first frame."""
    cams = {c.name: c for c in rig.cameras}
    grid_uv = {c.name: dict(zip(range(1, 16), c.project(np.array(GRID15)), strict=True))
               for c in rig.cameras}
    return number_pieces(frames, track_ids, cams, grid_uv,
                         dict.fromkeys(cams, DIAMETER_PX), EPIPOLAR_PX, FPS)


def _assert_front_eight_left_unnumbered(rig, pts: list[dict[int, np.ndarray]]) -> None:
    """Marker 8 unnumbered in the front over ``GAP`` while the side hides it: the step gives
    no number, and the front's 8 stays unnumbered there."""
    frames, track_ids = _frames(rig, pts,
                                lambda cam, k, m: -1 if (m == 8 and k in GAP) else m,
                                lambda cam, k, m: not (cam == 'cam_side' and m == 8
                                                       and k in GAP))
    out, given = _run(rig, frames, track_ids)
    assert given == 0
    assert _numbers(out, track_ids, 'cam_front', 8) == [
        -1 if k in GAP else 8 for k in range(FRAMES)]


def test_pieces_are_the_unnumbered_stretches_between_a_tracks_numbers(rig) -> None:
    """A track numbered but for three frames mid-pass gives one piece of three points, on the
    right frames; numbered tracks give none."""
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)],
                                lambda cam, k, m: -1 if (m == 8 and k in GAP) else m,
                                lambda cam, k, m: True)
    pieces = unnumbered_pieces(frames, track_ids, 'cam_side', FPS)
    assert [(p.track_id, len(p.times)) for p in pieces] == [(108, len(GAP))]
    assert np.allclose(pieces[0].times, [k * DT for k in GAP])


def test_a_stretch_hidden_in_the_other_camera_continues_its_marker(rig) -> None:
    """Marker 8 hidden in the side for three frames, its front track unnumbered there: the
    stretch lands where 8's own front points carried it and nobody else fits, so it is 8."""
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)],
                                lambda cam, k, m: -1 if (m == 8 and k in GAP) else m,
                                lambda cam, k, m: not (cam == 'cam_side' and m == 8
                                                       and k in GAP))
    out, given = _run(rig, frames, track_ids)
    assert given == len(GAP)
    assert _numbers(out, track_ids, 'cam_front', 8) == [8] * FRAMES


def test_a_stretch_both_cameras_left_unnumbered_is_paired_and_numbered(rig) -> None:
    """Marker 8 unnumbered in both cameras for three frames: the two stretches pair on their
    lines and their 3D points continue 8's path: 8 in both."""
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)],
                                lambda cam, k, m: -1 if (m == 8 and k in GAP) else m,
                                lambda cam, k, m: True)
    out, given = _run(rig, frames, track_ids)
    assert given == 2 * len(GAP)
    for cam in ('cam_side', 'cam_front'):
        assert _numbers(out, track_ids, cam, 8) == [8] * FRAMES


def test_a_stretch_far_from_where_its_marker_was_carried_is_refused(rig) -> None:
    """Marker 8's front track, unnumbered for three frames while the side hides it, lies 10 mm
    (more than a marker's diameter in the image) off where 8's path carried it: a stretch
    that does not come in where the marker went is not numbered."""
    pts = [_grid(k) for k in range(FRAMES)]
    for k in GAP:
        pts[k][8] = pts[k][8] + np.array([0.010, 0.0, 0.0])  # about 10 px aside
    _assert_front_eight_left_unnumbered(rig, pts)


def test_a_stretch_two_markers_continue_alike_is_refused(rig) -> None:
    """Markers 8 and 9 both lose their front numbers for the same three frames while the side
    hides them, and their front tracks there run along the middle between their paths: each
    stretch continues both markers about as well, so neither takes a number."""
    pts = [_grid(k) for k in range(FRAMES)]
    for k in GAP:
        mid = (pts[k][8] + pts[k][9]) / 2
        pts[k][8] = mid + np.array([0.0, 0.0, -0.0015])
        pts[k][9] = mid + np.array([0.0, 0.0, 0.0015])
    frames, track_ids = _frames(
        rig, pts,
        lambda cam, k, m: -1 if (m in (8, 9) and k in GAP) else m,
        lambda cam, k, m: not (cam == 'cam_side' and m in (8, 9) and k in GAP))
    out, _ = _run(rig, frames, track_ids)
    for m in (8, 9):
        assert _numbers(out, track_ids, 'cam_front', m) == [
            -1 if k in GAP else m for k in range(FRAMES)]


def test_a_stretch_touching_another_marker_is_refused(rig) -> None:
    """Marker 8 hidden in the side for three frames while marker 9, numbered in the front,
    comes within 4 mm of it there (about 4 px, under a marker's diameter): one camera cannot
    tell the two apart, so 8's front stretch stays unnumbered (it would be 8 without 9 near:
    ``test_a_stretch_hidden_in_the_other_camera_continues_its_marker``)."""
    pts = [_grid(k) for k in range(FRAMES)]
    for k in GAP:
        pts[k][9] = pts[k][8] + np.array([0.004, 0.0, 0.0])
    _assert_front_eight_left_unnumbered(rig, pts)
