"""Numbers carried over a break of a 2D track (``tracking.carried_numbers``): kept where the
other camera confirms them after the break or no other marker was near, withheld where a
neighbour was near and the other camera never confirms them.

The scene: the grid of 15 markers drifting with the bed, seen through the twin's true cameras,
every point numbered as its marker except where a test re-attaches the front's track of 8.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from projected import DT, GRID15, OFFSET

from dempath_recon.tracking.carried_numbers import withhold_carried
from dempath_recon.tracking.records import PixelFrame

GAP = (8, 9)  # the frames the front's track of marker 8 is lost in
FRAMES = 20
FLOW = np.array([0.0, 0.0004, 0.0008])  # the bed's drift [m/frame]
FPS = 1 / DT
DIAMETER_PX = {'cam_side': 8.0, 'cam_front': 8.0}  # a marker's size in each image [px]
# (the grid's markers lie 11.5-13 px apart in both images: within two diameters, crowded)
SMALL_PX = {'cam_side': 5.0, 'cam_front': 5.0}  # smaller markers: two diameters < the pitch


def _frames(rig, side_loses_8: bool, onto: int) -> tuple[list[PixelFrame], list[np.ndarray]]:
    """Both cameras' frames, every point numbered as its track: the front's track of 8 lost
    in ``GAP`` and re-attached after it at marker ``onto``'s spot (the front's own track of
    ``onto``, if another marker, lost from then on); the side gives 8 out throughout, or
    (``side_loses_8``) not after the gap's start."""
    frames, track_ids = [], []
    for k in range(FRAMES):
        at = {m: np.array(p) + k * FLOW for m, p in enumerate(GRID15, 1)}
        for cam, dt in (('cam_side', 0.0), ('cam_front', OFFSET)):
            model = next(c for c in rig.cameras if c.name == cam)
            seen, where = [], []
            for m in at:
                if cam == 'cam_side' and side_loses_8 and m == 8 and k >= GAP[0]:
                    continue
                if cam == 'cam_front' and m == 8 and k in GAP:
                    continue
                if cam == 'cam_front' and m == onto != 8 and k > GAP[-1]:
                    continue
                seen.append(m)
                where.append(at[onto] if cam == 'cam_front' and m == 8 and k > GAP[-1]
                             else at[m])
            frames.append(PixelFrame(cam, k * DT + dt, np.array(seen, np.int32),
                                     model.project(np.array(where)), np.ones(len(seen)), ()))
            track_ids.append(np.array(seen, np.int64))
    return frames, track_ids


def _after_gap(frames: list[PixelFrame], track_ids: list[np.ndarray]) -> set[int]:
    """The numbers the front's track 8 carries after the gap."""
    return {int(m) for k, (f, t) in enumerate(zip(frames, track_ids, strict=True))
            if f.camera == 'cam_front' and k // 2 > GAP[-1] for m in f.markers[t == 8]}


def _cameras(rig) -> dict:
    return {c.name: c for c in rig.cameras}


def test_a_number_the_other_camera_confirms_after_the_break_is_kept(rig) -> None:
    """The front's 8 re-attached on its own spot, the side giving 8 out: nothing changes."""
    frames, track_ids = _frames(rig, side_loses_8=False, onto=8)
    result = withhold_carried(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    assert all(np.array_equal(a.markers, b.markers)
               for a, b in zip(frames, result.frames, strict=True))
    assert sum(result.withheld.values()) == 0


def test_a_lone_marker_keeps_its_number_over_a_break(rig) -> None:
    """The same re-attachment on its own spot, with the side no longer giving 8 out: with
    markers 5 px across, no other lies within two diameters of the spot, so nothing else can
    be there and the number stays (a marker one camera sees alone after a gap); with 8 px
    markers the neighbours 12 px away might be, and it is withheld."""
    frames, track_ids = _frames(rig, side_loses_8=True, onto=8)
    result = withhold_carried(frames, track_ids, _cameras(rig), SMALL_PX, FPS)
    assert _after_gap(result.frames, track_ids) == {8}
    assert sum(result.withheld.values()) == 0
    result = withhold_carried(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    assert _after_gap(result.frames, track_ids) == {-1}


def test_a_number_nobody_confirms_where_a_neighbour_was_is_withheld(rig) -> None:
    """The front's track of 8 re-attached after the gap onto 9's spot (where its own track
    of 9 was till then), the side no longer giving 8 out: this camera alone cannot tell the
    spot is 8, so the piece is withheld (before the gap it stays), and the events say why."""
    frames, track_ids = _frames(rig, side_loses_8=True, onto=9)
    result = withhold_carried(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    assert _after_gap(frames, track_ids) == {8}
    assert _after_gap(result.frames, track_ids) == {-1}
    assert result.withheld == {'cam_front': FRAMES - GAP[-1] - 1, 'cam_side': 0}
    before = [f for k, f in enumerate(result.frames) if f.camera == 'cam_front' and k // 2 < 8]
    assert all(8 in f.markers for f in before)
    assert any('marker 8 withheld' in e and 'break of its 2D track' in e
               for f in result.frames for e in f.events)


def test_a_track_re_attached_onto_a_neighbour_is_withheld(rig) -> None:
    """The same re-attachment onto 9's spot, the side giving both out right: the side's 8
    does not confirm that spot (it lies off 8's epipolar line), so the number is withheld
    there and nowhere else."""
    frames, track_ids = _frames(rig, side_loses_8=False, onto=9)
    result = withhold_carried(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    assert _after_gap(result.frames, track_ids) == {-1}
    changed = sum(int((a.markers != b.markers).sum())
                  for a, b in zip(frames, result.frames, strict=True))
    assert changed == result.withheld['cam_front'] == FRAMES - GAP[-1] - 1
