"""Two markers that touched in one camera (``tracking.touching_exchange``): their numbers after
the contact kept where the other camera tells the tracks apart, withheld where it does not.

The scene: marker 1 still, marker 2 3 cm behind it along the side camera's line of sight at
frame ``CONTACT`` and moving across it, so that the side camera sees the two overlap there and
part, while the front camera sees them apart throughout; projected through the twin's true
cameras, every point numbered as its marker.
"""

from __future__ import annotations

import numpy as np

from dempath_recon.tracking.records import PixelFrame
from dempath_recon.tracking.touching_exchange import told_apart, windows, withhold_exchanged

FRAMES = 16
CONTACT = 6  # the frame the two overlap in the side camera
DT = 0.02  # frame period [s]
FPS = 1 / DT
OFFSET = 0.003  # the front camera exposes this much after the side one [s]
STILL = np.array([0.0, 0.0, 0.0])  # marker 1 [m]
DRIFT = np.array([0.0015, 0.0, 0.0005])  # marker 2's motion per frame [m]
DIAMETER_PX = {'cam_side': 8.0, 'cam_front': 8.0}  # a marker's size in each image [px]


def _scene(rig, front_loses: bool, returns_at: int = FRAMES, frames_n: int = FRAMES,
           ) -> tuple[list[PixelFrame], list[np.ndarray]]:
    """Both cameras' ``frames_n`` frames (``front_loses``: the front gives neither marker out
    after the contact, till frame ``returns_at``)."""
    side = next(c for c in rig.cameras if c.name == 'cam_side')
    centre = -np.asarray(side.R).T @ np.asarray(side.t).ravel()
    ray = (STILL - centre) / np.linalg.norm(STILL - centre)
    frames, track_ids = [], []
    for k in range(frames_n):
        at = {1: STILL, 2: STILL + 0.03 * ray + (k - CONTACT) * DRIFT}
        for cam, dt in (('cam_side', 0.0), ('cam_front', OFFSET)):
            model = next(c for c in rig.cameras if c.name == cam)
            gone = cam == 'cam_front' and front_loses and CONTACT < k < returns_at
            seen = [] if gone else [1, 2]
            uv = model.project(np.array([at[m] for m in seen])) if seen else np.zeros((0, 2))
            frames.append(PixelFrame(cam, k * DT + dt, np.array(seen, np.int32), uv,
                                     np.ones(len(seen)), ()))
            track_ids.append(np.array(seen, np.int64))
    return frames, track_ids


def _cameras(rig) -> dict:
    return {c.name: c for c in rig.cameras}


def test_the_scene_touches_in_one_camera_only(rig) -> None:
    """The side's two points overlap at the contact and part; the front's stay apart."""
    frames, _ = _scene(rig, front_loses=False)
    gap = {c: [float(np.linalg.norm(f.uv[0] - f.uv[1])) for f in frames if f.camera == c]
           for c in ('cam_side', 'cam_front')}
    assert gap['cam_side'][CONTACT] < 1.0
    assert gap['cam_side'][-1] > DIAMETER_PX['cam_side']
    assert min(gap['cam_front']) > 2 * DIAMETER_PX['cam_front']


def test_tracks_the_other_camera_tells_apart_keep_their_numbers(rig) -> None:
    """After the contact each side track pairs with its own number's front point and not
    with the other's: nothing changes."""
    frames, track_ids = _scene(rig, front_loses=False)
    result = withhold_exchanged(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    assert all(np.array_equal(a.markers, b.markers)
               for a, b in zip(frames, result.frames, strict=True))
    assert sum(result.withheld.values()) == 0


def test_tracks_nobody_tells_apart_are_withheld_after_the_contact(rig) -> None:
    """The front gives neither marker out after the contact: the side's two tracks may have
    exchanged there, so both numbers are withheld from the contact on (before it they stay),
    and the events say why."""
    frames, track_ids = _scene(rig, front_loses=True)
    result = withhold_exchanged(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    side = [(k, f) for k, f in enumerate(result.frames) if f.camera == 'cam_side']
    assert all(list(f.markers) == [1, 2] for k, f in side if k // 2 <= CONTACT)
    assert all(list(f.markers) == [-1, -1] for k, f in side if k // 2 > CONTACT)
    assert result.withheld == {'cam_side': 2 * (FRAMES - CONTACT - 1), 'cam_front': 0}
    assert any('touched' in e for f in result.frames for e in f.events)


LONG = 24  # frames of the longer scene: the side's two points apart (> a diameter) from 15 on
BACK = 19  # the front gives both out again from this frame (none from CONTACT + 1 till then)


def test_waiting_for_the_front_to_return_keeps_the_numbers(rig) -> None:
    """The front gives neither marker out for 12 frames after the contact, then both again:
    judged on the first frames after it where the side's two are apart (15-18) the two tracks
    are withheld to their end; waiting for the front's return (``wait``) it tells them apart,
    and nothing is withheld."""
    frames, track_ids = _scene(rig, front_loses=True, returns_at=BACK, frames_n=LONG)
    first = withhold_exchanged(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS)
    assert first.withheld['cam_side'] == 2 * (LONG - CONTACT - 1)
    waited = withhold_exchanged(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS, wait=True)
    assert sum(waited.withheld.values()) == 0
    assert all(np.array_equal(a.markers, b.markers)
               for a, b in zip(frames, waited.frames, strict=True))


def test_waiting_judges_only_the_tracks_that_left_the_contact(rig) -> None:
    """When the front returns only after marker 2's number moved to another side track, the
    return says nothing about the tracks that left the contact: both stay withheld."""
    frames, track_ids = _scene(rig, front_loses=True, returns_at=BACK, frames_n=LONG)
    for k, f in enumerate(frames):
        if f.camera == 'cam_side' and k // 2 >= BACK - 2:
            track_ids[k] = np.where(f.markers == 2, 7, track_ids[k])
    waited = withhold_exchanged(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS, wait=True)
    # marker 1's track from the contact on, and marker 2's first track till it ends
    assert waited.withheld['cam_side'] == (LONG - CONTACT - 1) + (BACK - 2 - CONTACT - 1)
    assert waited.withheld['cam_front'] == 0


def test_tracks_the_other_camera_tells_apart_exchanged_take_each_others_number(rig) -> None:
    """The side's two tracks leave the contact exchanged (each carries the other's number
    from then on) and the front sees the two apart: withheld by default; with ``swap`` each
    point gets its own marker's number back, and nothing is withheld."""
    frames, track_ids = _scene(rig, front_loses=False, frames_n=LONG)
    for k, f in enumerate(frames):
        if f.camera == 'cam_side' and k // 2 > CONTACT:
            frames[k] = f._replace(markers=f.markers[::-1].copy())
            track_ids[k] = track_ids[k][::-1].copy()
    withheld = withhold_exchanged(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS, wait=True)
    assert withheld.withheld['cam_side'] == 2 * (LONG - CONTACT - 1)
    swapped = withhold_exchanged(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS, wait=True,
                                 swap=True)
    assert swapped.swapped == {'cam_side': 2 * (LONG - CONTACT - 1), 'cam_front': 0}
    assert sum(swapped.withheld.values()) == 0
    assert all(list(f.markers) == [1, 2] for f in swapped.frames)
    assert any('renumbered' in e for f in swapped.frames for e in f.events)


def test_a_swap_onto_a_number_another_point_keeps_is_withheld(rig) -> None:
    """Where a frame after the contact gives one of the two numbers on a third point too,
    the swapped point there would repeat it: that point is withheld instead."""
    frames, track_ids = _scene(rig, front_loses=False, frames_n=LONG)
    for k, f in enumerate(frames):
        if f.camera == 'cam_side' and k // 2 > CONTACT:
            frames[k] = f._replace(markers=f.markers[::-1].copy())
            track_ids[k] = track_ids[k][::-1].copy()
    last = len(frames) - 2  # the side's last frame: marker 2's track loses its number there,
    f = frames[last]  # and a third point elsewhere carries 1
    frames[last] = f._replace(markers=np.array([2, -1, 1], np.int32),
                              uv=np.vstack([f.uv, [[100.0, 100.0]]]),
                              confidence=np.ones(3))
    track_ids[last] = np.array([2, 1, 9], np.int64)
    swapped = withhold_exchanged(frames, track_ids, _cameras(rig), DIAMETER_PX, FPS, wait=True,
                                 swap=True)
    assert list(swapped.frames[last].markers) == [-1, -1, 1]
    assert swapped.withheld['cam_side'] == 1


def test_the_runs_judged_skip_frames_without_the_other_camera() -> None:
    """Without waiting the first four after-frames are judged whatever the other camera
    gives; waiting, only those it gives a point in, four by four."""
    after = np.arange(10)
    returned = np.array([False] * 3 + [True] * 7)
    assert [r.tolist() for r in windows(after, returned, wait=False)] == [[0, 1, 2, 3]]
    assert [r.tolist() for r in windows(after, returned, wait=True)] == [[3, 4, 5, 6],
                                                                        [7, 8, 9]]


def test_an_exchange_that_fits_as_well_is_not_told_apart() -> None:
    """The pairing as numbered must beat the exchanged one by the margin: 0.4 px against
    1.5 px is told apart, 1.0 against 1.5 is not, and no pair at all is not."""
    assert told_apart(np.array([0.4, 0.3]), np.array([1.5, 1.6]), 8.0)
    assert not told_apart(np.array([1.0, 0.9]), np.array([1.5, 1.6]), 8.0)
    assert not told_apart(np.array([np.nan]), np.array([np.nan]), 8.0)
