"""The tool's speed as a bound on each camera's frame-to-frame links (``tracking.speed_bound``):
a track never takes a spot its marker cannot have reached since it was last seen.

Synthetic detections at exact positions, a real ``MarkerTracker``, the twin's true cameras.
"""

from __future__ import annotations

import numpy as np
import pytest

from dempath_calib.camera import StereoCalibration
from dempath_recon.tracking.associate import MarkerGrid, depth, marker_diameter_px
from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.linker import SLACK_PX, MarkerTracker, TrackerConfig
from dempath_recon.tracking.records import StereoTrackConfig
from dempath_recon.tracking.speed_bound import OUTRUN, image_speed_bound
from dempath_recon.tracking.stereo import StereoMarkerTracker

DT = 0.02  # frame period [s]
BOUND = 500.0  # image speed bound of these cases [px/s]: 10 px a frame
GRID = MarkerGrid(layout_m=((-0.05, 0.0, -0.05), (0.05, 0.0, -0.05), (0.0, 0.0, 0.05)))


def dets(uv: list[list[float]]) -> Detections:
    """Detections at exact positions (px)."""
    return Detections(np.asarray(uv, np.float64).reshape(-1, 2), np.ones(len(uv)),
                      np.full(len(uv), 3.0))


def covered_then_neighbour(bound: float) -> list[np.ndarray]:
    """Marker 1 at rest at (100, 100) px for 3 frames, then covered; in its place a neighbour's
    spot 15 px away (inside the 25 px gate, beyond 10 px a frame + slack). The marker
    numbers given to that spot, frame by frame."""
    tracker = MarkerTracker(TrackerConfig(max_image_speed_px_s=bound))
    tracker.seed(np.array([[100.0, 100.0]]), np.array([1], np.int32), -DT)
    out = []
    for k in range(6):
        spot = [100.0, 100.0] if k < 3 else [115.0, 100.0]
        frame = tracker.update(k * DT, dets([spot]))
        out.append(frame.markers[np.all(frame.uv == spot, axis=1)])
    return out


def test_a_spot_beyond_the_markers_reach_is_not_linked() -> None:
    """A neighbour 15 px from a marker at rest, one frame after it was seen, is beyond 10 px a
    frame plus the slack: it starts a new track and marker 1 stays lost. With no bound (0, the
    rule off) the track takes the neighbour's spot and carries number 1 onto it."""
    bounded = covered_then_neighbour(BOUND)
    assert all(m.tolist() == [-1] for m in bounded[3:])
    unbounded = covered_then_neighbour(0.0)
    assert all(m.tolist() == [1] for m in unbounded[3:])


def test_a_spot_within_reach_is_linked_and_reach_grows_while_lost() -> None:
    """A marker moving 9 px a frame stays linked under a 10 px-a-frame bound; once covered for
    two frames, its re-attachment 25 px from where it was last seen is within 3 frames of
    motion and is made."""
    tracker = MarkerTracker(TrackerConfig(max_image_speed_px_s=BOUND))
    tracker.seed(np.array([[100.0, 100.0]]), np.array([1], np.int32), -DT)
    for k in range(4):
        frame = tracker.update(k * DT, dets([[100.0 + 9.0 * (k + 1), 100.0]]))
        assert frame.markers.tolist() == [1]
    tracker.update(4 * DT, dets([]))
    tracker.update(5 * DT, dets([]))
    frame = tracker.update(6 * DT, dets([[136.0 + 25.0, 100.0]]))
    assert frame.markers.tolist() == [1]
    assert BOUND * 3 * DT + SLACK_PX >= 25.0


def test_the_bound_is_the_tool_speed_at_the_grids_depth(rig: StereoCalibration) -> None:
    """``OUTRUN`` times the tool's speed, in px/s at the grid's median depth (f / Z); none
    when the speed is not known."""
    cam = rig.cameras[0]
    z = float(np.median([depth(cam, p) for p in GRID.points()[1]]))
    f = 0.5 * float(cam.K[0, 0] + cam.K[1, 1])
    assert image_speed_bound(cam, GRID, 0.5) == pytest.approx(OUTRUN * 0.5 * f / z)
    assert image_speed_bound(cam, GRID, 0.0) == 0.0


def test_the_stereo_tracker_gives_each_camera_its_bound(rig: StereoCalibration) -> None:
    """With the tool's speed set, each camera's linker gets that camera's bound; unset (the
    default), none; a bound the tracker settings give is kept. Each camera's held links get
    the markers' image diameter as their rival distance."""
    cams = {c.name: c for c in rig.cameras}
    fast = StereoMarkerTracker(cams, StereoTrackConfig(grid=GRID, tool_speed_m_s=1.0))
    for name, cam in cams.items():
        got = fast.state.trackers[name].config.max_image_speed_px_s
        assert got == pytest.approx(image_speed_bound(cam, GRID, 1.0)) and got > 0
        rival = fast.state.trackers[name].config.hold_rival_px
        assert rival == pytest.approx(marker_diameter_px(cam, GRID, 0.008)) and rival > 0
    plain = StereoMarkerTracker(cams, StereoTrackConfig(grid=GRID))
    assert all(t.config.max_image_speed_px_s == 0 for t in plain.state.trackers.values())
    given = StereoMarkerTracker(cams, StereoTrackConfig(
        grid=GRID, tool_speed_m_s=1.0, tracker=TrackerConfig(max_image_speed_px_s=123.0)))
    assert all(t.config.max_image_speed_px_s == 123.0 for t in given.state.trackers.values())


@pytest.mark.parametrize(('make', 'field'), [
    (lambda: StereoTrackConfig(tool_speed_m_s=-1.0), 'tool_speed_m_s'),
    (lambda: StereoTrackConfig(tool_speed_m_s=float('nan')), 'tool_speed_m_s'),
    (lambda: TrackerConfig(max_image_speed_px_s=-5.0), 'max_image_speed_px_s'),
    (lambda: TrackerConfig(hold_rival_px=-1.0), 'hold_rival_px'),
])
def test_bad_speeds_are_refused_by_name(make, field: str) -> None:
    """A negative or NaN speed is one ValueError naming the field."""
    with pytest.raises(ValueError, match=field):
        make()
