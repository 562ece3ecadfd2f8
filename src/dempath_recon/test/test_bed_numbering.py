"""Numbering by the bed's motion over the whole pass (``tracking.bed_numbering``): a marker no
camera numbered, placed by where the markers around it went.

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
from test_crowded_pair import replay
from test_joint_fill import EPIPOLAR_PX, FPS, FRAMES, _frames, _grid, _numbers

from dempath_recon.tracking import bed_field
from dempath_recon.tracking.bed_field import FLOOR_M, BedField, nearest_given, rest_points
from dempath_recon.tracking.bed_numbering import number_by_bed
from dempath_recon.tracking.piece_numbering import unnumbered_pieces
from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.trajectories import marker_histories
from dempath_recon.tracking.whole_pass import Pass, marker_points_3d

DIAMETER_PX = 8.0  # a marker's diameter in both images [px]
OUT = range(6, FRAMES)  # the frames where a covered marker has come out of the sand
LAYOUT = {m: np.array(p) for m, p in enumerate(GRID15, 1)}
STORED = Path(__file__).parent / 'data' / 'crowded_pair_frames.json'


def _run(rig, frames, track_ids) -> tuple[list[PixelFrame], int]:
    """:func:`number_by_bed` with the rig's cameras and the grid at the first frame."""
    cams = {c.name: c for c in rig.cameras}
    grid_uv = {c.name: dict(zip(range(1, 16), c.project(np.array(GRID15)), strict=True))
               for c in rig.cameras}
    return number_by_bed(frames, track_ids, cams, grid_uv, LAYOUT,
                         dict.fromkeys(cams, DIAMETER_PX), EPIPOLAR_PX, FPS)


def _covered(hidden: set[int], cameras: tuple[str, ...]):
    """``(numbered, seen)`` for ``_frames``: the ``hidden`` markers never numbered, seen in
    ``cameras`` only from ``OUT`` on (covered at the grid fit); every other marker numbered
    and seen throughout."""
    def numbered(cam: str, k: int, m: int) -> int:
        return -1 if m in hidden else m

    def seen(cam: str, k: int, m: int) -> bool:
        return m not in hidden or (cam in cameras and k in OUT)
    return numbered, seen


def test_the_field_places_a_marker_where_its_neighbours_went() -> None:
    """The bed sheared (the tool's column pushed 30 mm along the travel, the far column not at
    all): the middle marker, never seen, is placed between, and its spread covers the error."""
    rest = dict(LAYOUT)
    times = np.arange(10) * DT
    push = np.array([0.0, 0.0, 0.03])

    def at(m: int, t: float) -> np.ndarray:
        share = (0.025 - rest[m][0]) / 0.05  # 1 at x = -25 mm, 0 at x = +25 mm
        return rest[m] + share * push * t / times[-1]
    own = {m: (times, np.array([at(m, t) for t in times])) for m in rest if m != 8}
    placed = BedField(own, rest, FPS).place(8, times)
    err = np.linalg.norm(placed.xyz - np.array([at(8, t) for t in times]), axis=1)
    assert np.all(placed.spread >= FLOOR_M)
    assert np.all(err <= placed.spread)
    assert err[-1] < 0.005  # half the push's 15 mm at the middle column, within 5 mm


def _column_pushed(sheared: bool) -> tuple[np.ndarray, np.ndarray]:
    """Marker 3's error and spread [m] at the last instant, never numbered, when the tool's
    column (markers 1-5, x = -25 mm) is pushed 60 mm along the travel and the other columns
    stay (a tine's step across the bed), placed by the sheared or the isotropic field."""
    rest = dict(LAYOUT)
    times = np.arange(10) * DT
    push = np.array([0.0, 0.0, 0.06])

    def at(m: int, t: float) -> np.ndarray:
        return rest[m] + (m <= 5) * push * t / times[-1]
    own = {m: (times, np.array([at(m, t) for t in times])) for m in rest if m != 3}
    across, along = ((bed_field.SHEAR_ACROSS, bed_field.SHEAR_ALONG) if sheared
                     else (bed_field.SIGMA_PITCH, bed_field.SIGMA_PITCH))
    placed = BedField(own, rest, FPS, across=across, along=along).place(3, times)
    return np.linalg.norm(placed.xyz[-1] - at(3, times[-1])), placed.spread[-1]


def test_the_sheared_field_carries_a_marker_with_its_own_column() -> None:
    """The tool's column pushed 60 mm, the next column still: weighed by the rest distance the
    middle column's markers, as near as the column's own, pull the covered marker 3 back by
    half the push; weighed across and along the travel (``bed_field.SHEAR_ACROSS``, ``_ALONG``) it
    goes with its column, within 5 mm, and its spread shrinks."""
    err_iso, spread_iso = _column_pushed(False)
    err_shear, spread_shear = _column_pushed(True)
    assert err_iso > 0.02
    assert err_shear < 0.005
    assert err_shear <= spread_shear < spread_iso


def test_a_marker_no_camera_numbered_is_numbered_where_the_bed_carried_it(rig) -> None:
    """Marker 8 covered at the grid fit, out in both cameras from frame 6 and never numbered:
    its two tracks pair in 3D where the bed's flow carried its grid point, and nobody else
    fits there: 8 in both cameras (but the side's first point and the front's last, which
    the other camera's piece does not reach: the front exposes 3 ms after the side)."""
    numbered, seen = _covered({8}, ('cam_side', 'cam_front'))
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)], numbered, seen)
    out, given = _run(rig, frames, track_ids)
    assert given == 2 * len(OUT) - 2
    first, last = OUT[0], OUT[-1]
    assert _numbers(out, track_ids, 'cam_side', 8) == [
        -2 if k not in OUT else (-1 if k == first else 8) for k in range(FRAMES)]
    assert _numbers(out, track_ids, 'cam_front', 8) == [
        -2 if k not in OUT else (-1 if k == last else 8) for k in range(FRAMES)]


def test_a_marker_out_in_one_camera_is_numbered_there(rig) -> None:
    """Marker 8 out in the front only: its front track alone follows its carried point: 8."""
    numbered, seen = _covered({8}, ('cam_front',))
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)], numbered, seen)
    out, given = _run(rig, frames, track_ids)
    assert given == len(OUT)
    assert _numbers(out, track_ids, 'cam_front', 8) == [-2 if k not in OUT else 8
                                                        for k in range(FRAMES)]


def test_a_piece_far_from_every_carried_point_is_refused(rig) -> None:
    """Marker 8 out in the front only, but 15 mm off where the bed carried it (beyond the
    field's gate where all its neighbours moved alike): no number."""
    pts = [_grid(k) for k in range(FRAMES)]
    for k in OUT:
        pts[k][8] = pts[k][8] + np.array([0.0, 0.015, 0.0])
    numbered, seen = _covered({8}, ('cam_front',))
    frames, track_ids = _frames(rig, pts, numbered, seen)
    out, given = _run(rig, frames, track_ids)
    assert given == 0
    assert set(_numbers(out, track_ids, 'cam_front', 8)) == {-2, -1}


def test_two_covered_markers_between_their_places_are_refused(rig) -> None:
    """Markers 8 and 13 (neighbours across the travel) both covered at the fit and out in the
    front only, their spots 1.5 mm either side of the middle between their carried points:
    each fits both markers about as well, so neither is numbered."""
    pts = [_grid(k) for k in range(FRAMES)]
    for k in OUT:
        mid = (pts[k][8] + pts[k][13]) / 2
        pts[k][8] = mid + np.array([-0.0015, 0.0, 0.0])
        pts[k][13] = mid + np.array([0.0015, 0.0, 0.0])
    numbered, seen = _covered({8, 13}, ('cam_front',))
    frames, track_ids = _frames(rig, pts, numbered, seen)
    out, given = _run(rig, frames, track_ids)
    assert given == 0
    for m in (8, 13):
        assert set(_numbers(out, track_ids, 'cam_front', m)) == {-2, -1}


def _front_piece_nearest_given(rig, side_gives_eight: bool) -> float:
    """:func:`nearest_given` of the front's unnumbered piece of marker 8 (out from ``OUT``),
    the side giving 8 out throughout or hiding it."""
    cams = {c.name: c for c in rig.cameras}
    grid_uv = {c.name: dict(zip(range(1, 16), c.project(np.array(GRID15)), strict=True))
               for c in rig.cameras}

    def numbered(cam: str, k: int, m: int) -> int:
        return -1 if (m == 8 and cam == 'cam_front') else m

    def seen(cam: str, k: int, m: int) -> bool:
        return m != 8 or (cam == 'cam_front' and k in OUT) or (cam == 'cam_side'
                                                               and side_gives_eight)
    frames, track_ids = _frames(rig, [_grid(k) for k in range(FRAMES)], numbered, seen)
    ps = Pass(cams, {c: marker_histories(frames, c) for c in sorted(cams)},
              marker_points_3d(frames, cams, FPS), grid_uv, 0.0, EPIPOLAR_PX, FPS)
    field = BedField(ps.own_3d, rest_points(grid_uv, cams, LAYOUT), FPS, 0.0)
    piece = unnumbered_pieces(frames, track_ids, 'cam_front', FPS)
    assert [p.track_id for p in piece] == [108]
    return nearest_given(ps, field, (piece[0],))


def test_a_piece_on_the_lines_of_a_marker_its_camera_lacks_has_a_certain_rival(rig) -> None:
    """The front's unnumbered piece of 8 lies on the side's lines of 8, which the front does
    not give out: it may be 8, so the field's rivals include it at distance 0; with the side
    hiding 8 the nearest marker given out is a neighbour, several spreads away."""
    assert _front_piece_nearest_given(rig, True) == 0.0
    assert _front_piece_nearest_given(rig, False) > 3.0


def _right_and_wrong(bed: bool) -> tuple[set[tuple[str, float, int]], set[tuple[str, float, int]]]:
    """A stored tuning look (``crowded_pair_frames.json``) through the whole tracker with the
    step on or off: the points given out on their own marker's spot and on another's."""
    data, frames = replay(STORED, bed_numbering=bed)
    ids: list[int] = data['marker_ids']
    truth = {(f['camera'], round(f['stamp_s'] * 1e6)): np.array(f['true_uv'])
             for f in data['frames']}
    right, wrong = set(), set()
    for frame in frames:
        true_uv = truth[(frame.camera, round(frame.stamp_s * 1e6))]
        for m, p in zip(frame.markers.tolist(), frame.uv, strict=True):
            if m >= 0:
                ok = float(np.linalg.norm(true_uv[ids.index(m)] - p)) <= 3.0
                (right if ok else wrong).add((frame.camera, round(frame.stamp_s, 3), m))
    return right, wrong


def test_the_pipeline_with_the_step_keeps_every_right_number_and_adds_no_wrong_one() -> None:
    """Through the whole tracker (``StereoTrackConfig.bed_numbering``) on a stored look: every
    point numbered right without the step is numbered right with it, and no point goes out
    with another marker's number that did not without it."""
    right_on, wrong_on = _right_and_wrong(True)
    right_off, wrong_off = _right_and_wrong(False)
    assert right_off <= right_on
    assert wrong_on <= wrong_off
    assert right_off  # the look is numbered at all
