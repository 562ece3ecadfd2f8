"""The whole pass audited in 3D (``tracking.pass_audit``): a piece of track carries one
number, and a stretch its own marker's line does not explain while another marker's 3D path
does is renumbered or taken out.

Scenes are the 15-marker grid moved by a slow bed flow and projected through the twin's true
cameras, each camera's points given out as a frame-by-frame pipeline might have left them, so
each point's marker is known.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from projected import DT, GRID15, OFFSET

from dempath_recon.tracking.pass_audit import Points, audit_pass, fit_path
from dempath_recon.tracking.records import PixelFrame

FLOW = np.array([0.0, 0.0004, 0.0008])  # the bed's slow heave and travel [m/frame]
FRAMES = 20
FPS = 1 / DT
DIAMETER_PX = {'cam_side': 8.0, 'cam_front': 8.0}  # a marker's size in each image [px]


def _grid(k: int) -> dict[int, np.ndarray]:
    """The 15 markers at frame ``k`` [m]."""
    return {m: np.array(p) + k * FLOW for m, p in enumerate(GRID15, 1)}


def _frames(rig, numbered, ids, spot=None) -> tuple[list[PixelFrame], list[np.ndarray]]:
    """Both cameras' frames: ``numbered[cam](k, m)`` the number a camera gave marker ``m``'s
    point at frame ``k`` (-1 none), ``ids[cam](k, m)`` its track (None: not seen),
    ``spot(cam, k, m)`` the marker whose place the point lies at (default ``m``)."""
    frames, track_ids = [], []
    for k in range(FRAMES):
        at = _grid(k)
        for cam, dt in (('cam_side', 0.0), ('cam_front', OFFSET)):
            model = next(c for c in rig.cameras if c.name == cam)
            seen = [m for m in at if ids[cam](k, m) is not None]
            where = [at[m if spot is None else spot(cam, k, m)] for m in seen]
            frames.append(PixelFrame(cam, k * DT + dt,
                                     np.array([numbered[cam](k, m) for m in seen], np.int32),
                                     model.project(np.array(where)), np.ones(len(seen)), ()))
            track_ids.append(np.array([ids[cam](k, m) for m in seen], np.int64))
    return frames, track_ids


def _numbers(frames, track_ids, cam: str, track: int, first: int) -> set[int]:
    """The numbers ``cam``'s points of ``track`` carry from frame ``first`` on."""
    return {int(m) for k, (f, t) in enumerate(zip(frames, track_ids, strict=True))
            if f.camera == cam and k // 2 >= first for m in f.markers[t == track]}


def _cameras(rig) -> dict:
    return {c.name: c for c in rig.cameras}


def _plain() -> dict:
    return {c: (lambda k, m: m) for c in ('cam_side', 'cam_front')}


def test_a_pass_numbered_right_is_left_as_it_is(rig) -> None:
    """Every marker numbered right in both cameras all pass: nothing is taken out."""
    frames, track_ids = _frames(rig, _plain(), _plain())
    result = audit_pass(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    assert all(np.array_equal(a.markers, b.markers)
               for a, b in zip(frames, result.frames, strict=True))
    assert sum(result.renumbered.values()) == sum(result.withheld.values()) == 0


def test_a_piece_of_track_that_changes_its_number_keeps_the_one_it_carried_longest(
        rig) -> None:
    """The front's track of 8 carries 8 for 14 frames, then 9 (a late rule named it after
    the side's 9) while no front point gives 8 out: the piece is one marker, so it is 8 again
    (and unnumbered where another point of the frame gives 8 out)."""
    numbered = {'cam_side': lambda k, m: m,
                'cam_front': lambda k, m: -1 if m == 9 and k >= 14 else (
                    9 if m == 8 and k >= 14 else m)}
    frames, track_ids = _frames(rig, numbered, _plain())
    result = audit_pass(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    assert _numbers(result.frames, track_ids, 'cam_front', 8, 14) == {8}
    assert result.renumbered['cam_front'] == FRAMES - 14


def _moved(numbered_nine: bool):
    """The front's track of 8 that slid onto 9's spot at frame 10 and stayed there, still
    numbered 8; the front's own track of 9 lost then (or still giving 9 out)."""
    numbered = {'cam_side': lambda k, m: m, 'cam_front': lambda k, m: m}
    ids = {'cam_side': lambda k, m: m,
           'cam_front': lambda k, m: None if m == 9 and k >= 10 and not numbered_nine else m}

    def spot(cam: str, k: int, m: int) -> int:
        return 9 if cam == 'cam_front' and m == 8 and k >= 10 else m

    return numbered, ids, spot


def test_a_track_that_moved_onto_a_neighbour_takes_its_number(rig) -> None:
    """Off the side's line of 8 and on 9's 3D path (the side's 9 all pass, the front's till
    it was lost): the stretch is 9's, and no front point gives 9 out then: renumbered 9."""
    frames, track_ids = _frames(rig, *_moved(numbered_nine=False))
    result = audit_pass(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    assert _numbers(frames, track_ids, 'cam_front', 8, 10) == {8}
    assert _numbers(result.frames, track_ids, 'cam_front', 8, 10) == {9}
    assert _numbers(result.frames, track_ids, 'cam_front', 8, 0) == {8, 9}
    assert not any('cam_side' in e for f in result.frames for e in f.events)


def test_a_moved_track_is_taken_out_where_its_neighbour_is_given_out(rig) -> None:
    """The same, with the front still giving 9 out in those frames: the stretch is taken out,
    and the frames' events say why."""
    frames, track_ids = _frames(rig, *_moved(numbered_nine=True))
    result = audit_pass(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    assert _numbers(result.frames, track_ids, 'cam_front', 8, 10) == {-1}
    assert result.withheld['cam_front'] == FRAMES - 10
    assert any('pass audit' in e and 'marker 8 withheld' in e
               for f in result.frames for e in f.events)


def test_a_path_follows_a_marker_and_drops_a_stretch_on_a_neighbour(rig) -> None:
    """Marker 8's path through its points of both cameras (their own stamps) lies within
    0.2 mm of where it was; five front points on 9's spot are given no weight."""
    cams = [c for name in ('cam_front', 'cam_side') for c in rig.cameras if c.name == name]
    rows = []
    for k in range(FRAMES):
        at = _grid(k)
        for c, dt in ((0, OFFSET), (1, 0.0)):
            place = at[9] if c == 0 and 8 <= k < 13 else at[8] + FLOW * dt / DT
            rows.append((c, k * DT + dt, *cams[c].project(place[None])[0]))
    arr = np.array(rows)
    pts = Points(arr[:, 0].astype(np.int64), arr[:, 1], arr[:, 2:4])
    fitted = fit_path(cams, pts, np.array([8.0, 8.0]), FPS)
    assert fitted is not None
    path, weight = fitted
    on_nine = (pts.cam == 0) & (pts.times >= 8 * DT) & (pts.times < 13 * DT)
    assert np.all(weight[on_nine] == 0)
    assert np.all(weight[~on_nine] > 0.5)
    side = pts.cam == 1
    err = path.at(pts.times[side], FPS) - np.array([_grid(k)[8] for k in range(FRAMES)])
    assert float(np.abs(err).max()) < 2e-4


def test_without_renumbering_the_audit_only_withholds(rig) -> None:
    """The two cases the audit renumbers (a piece's later number, a track moved onto a
    neighbour the front no longer gives out), audited as the pipeline does by default
    (``StereoTrackConfig.audit_renumber`` off): both stretches are withheld, never given the
    number the audit found, and the points before them keep theirs."""
    numbered = {'cam_side': lambda k, m: m,
                'cam_front': lambda k, m: -1 if m == 9 and k >= 14 else (
                    9 if m == 8 and k >= 14 else m)}
    frames, track_ids = _frames(rig, numbered, _plain())
    result = audit_pass(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS, renumber=False)
    assert _numbers(result.frames, track_ids, 'cam_front', 8, 14) == {-1}
    assert result.renumbered['cam_front'] == 0 < result.withheld['cam_front']
    frames, track_ids = _frames(rig, *_moved(numbered_nine=False))
    result = audit_pass(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS, renumber=False)
    assert _numbers(result.frames, track_ids, 'cam_front', 8, 10) == {-1}
    assert _numbers(result.frames, track_ids, 'cam_front', 8, 0) == {8, -1}
    assert sum(result.renumbered.values()) == 0
