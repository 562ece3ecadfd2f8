"""Each detected spot's size and mass (integrated likelihood), carried to the tracker's frames
(``Detections.mass``, ``PixelFrame.size_px`` / ``PixelFrame.mass``)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import Detections, DetectorConfig, MarkerDetector
from dempath_recon.tracking.stereo import StereoMarkerTracker, StereoTrackConfig

SHAPE = (240, 320)
RADIUS = 4.0  # px: an 8 px marker
LONE = np.array([[60.0, 60.0], [140.0, 60.0], [220.0, 60.0]])  # px
PAIR = np.array([[100.0, 160.0], [106.5, 160.0]])  # two touching markers [px]
DT = 0.02  # frame period [s]
GRID = ((-0.05, 0.0, -0.05), (0.05, 0.0, -0.05), (0.0, 0.0, 0.05))  # markers 1, 2, 3 [m]


def masses(buried: float, seed: int) -> tuple[np.ndarray, np.ndarray, Detections]:
    """The lone markers' masses (3,) buried by ``buried`` of their height, the touching pair's
    (2,), and the detections."""
    rng = np.random.default_rng(seed)
    det = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS))
    truth = np.vstack([LONE, PAIR])
    found = det.detect_jpeg(spot_image(SHAPE, truth, RADIUS, rng,
                                       buried=np.array([buried] * 3 + [0.0, 0.0])))
    assert found.mass is not None
    assert len(found.uv) == len(truth)
    near = np.linalg.norm(truth[:, None] - found.uv[None], axis=2).argmin(axis=1)
    assert len(set(near.tolist())) == len(truth)
    return found.mass[near[:3]], found.mass[near[3:]], found


def test_a_spots_mass_falls_as_its_marker_sinks() -> None:
    """Whole markers give about the same mass; a quarter buried gives less, half buried less
    again (under half of a whole one's): the mass says how much of a marker is seen."""
    whole, _, _ = masses(0.0, 3)
    quarter, _, _ = masses(0.25, 3)
    half, _, _ = masses(0.5, 3)
    assert whole.min() > 0
    assert whole.max() / whole.min() < 1.15
    assert quarter.max() < 0.85 * whole.min()
    assert half.max() < quarter.min()
    assert half.max() < 0.5 * whole.min()


def test_a_split_blobs_markers_share_its_mass() -> None:
    """Two touching markers split apart take equal shares of their blob's mass, each about one
    marker's (not the blob's whole, twice a marker's)."""
    whole, pair, found = masses(0.0, 5)
    assert found.parted is not None
    assert int(found.parted.sum()) == 2
    assert pair[0] == pair[1]
    assert 0.6 * whole.mean() < pair[0] < 1.25 * whole.mean()


def test_the_tracker_carries_each_points_spot_size_and_mass(rig) -> None:  # type: ignore[no-untyped-def]
    """Every point of a tracker's frame carries the size and mass of the detection it took,
    whatever order the tracks give out; without a measured mass, NaN."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=MarkerGrid(layout_m=GRID)))
    xyz = np.array(GRID)
    size, mass = np.array([3.0, 4.0, 5.0]), np.array([10.0, 12.0, 14.0])
    for k in range(3):
        for name in ('cam_side', 'cam_front'):
            uv = cams[name].project(xyz)
            frame = tracker.update_detections(name, k * DT, Detections(
                uv, np.ones(3), size, mass=mass))
            assert frame.size_px is not None
            assert frame.mass is not None
            assert len(frame.uv) == 3
            which = np.linalg.norm(frame.uv[:, None] - uv[None], axis=2).argmin(axis=1)
            assert sorted(which.tolist()) == [0, 1, 2]
            np.testing.assert_array_equal(frame.size_px, size[which])
            np.testing.assert_array_equal(frame.mass, mass[which])
    frame = tracker.update_detections('cam_side', 3 * DT, Detections(
        cams['cam_side'].project(xyz), np.ones(3), size))
    assert frame.mass is not None
    assert np.isnan(frame.mass).all()
    assert frame.size_px is not None
    assert np.isfinite(frame.size_px).all()
