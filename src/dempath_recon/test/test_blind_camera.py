"""A camera whose frames hold no marker the detector can see is said once, with the reason.

Red clay on grey sand gave 0 markers found in a whole held-out look (session 16) and nothing said
why: the detector looks for blue clay. Real OpenCV JPEG frames, the real detector and tracker.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.stereo import BLIND_FRAMES, StereoMarkerTracker, StereoTrackConfig

GREY_SAND = np.array([0.48, 0.50, 0.52])
RED_CLAY = np.array([0.28, 0.38, 0.72])
BLUE_CLAY = np.array([0.62, 0.22, 0.10])
CENTRES = np.array([[120.0, 100.0], [220.0, 110.0], [320.0, 95.0]])
GRID = ((-0.05, 0.0), (0.0, 0.0), (0.05, 0.0))


def events_of(rig, clay: np.ndarray) -> list[str]:
    """Every event of the side camera over BLIND_FRAMES frames of markers in ``clay``."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, StereoTrackConfig(grid=MarkerGrid(layout_m=GRID)))
    rng = np.random.default_rng(3)
    events: list[str] = []
    for k in range(BLIND_FRAMES + 2):
        jpeg = spot_image((240, 440), CENTRES, 6.0, rng, sand_bgr=GREY_SAND, clay_bgr=clay)
        image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        det = tracker.detectors['cam_side'].detect(image)
        events += tracker.update_detections('cam_side', k / 50, det).events
    return events


def test_red_markers_are_said_to_be_outside_what_the_detector_looks_for(rig) -> None:
    """Red clay: one event after BLIND_FRAMES frames naming blue clay and the threshold."""
    said = [e for e in events_of(rig, RED_CLAY) if 'no marker found' in e]
    assert len(said) == 1
    assert said[0].startswith(f'cam_side: no marker found in the first {BLIND_FRAMES} frames')
    assert 'blue clay' in said[0] and '0.15' in said[0]


def test_blue_markers_say_nothing_of_the_kind(rig) -> None:
    """Blue clay on the same sand is found, and nothing is said."""
    assert not [e for e in events_of(rig, BLUE_CLAY) if 'no marker found' in e]
