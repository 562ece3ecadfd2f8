"""Scenes of 3D points projected through the twin's true cameras, for the numbering tests: each
detection's marker is known, and a test reads back the number a camera gave a point.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

from dempath_recon.tracking.detect import Detections
from dempath_recon.tracking.records import PixelFrame, StereoTrackConfig
from dempath_recon.tracking.stereo import StereoMarkerTracker

DT = 0.02  # frame period [s]
OFFSET = 0.003  # the front camera exposes this much after the side one [s]
GRID15 = tuple((x, 0.0, z) for x in (-0.025, 0.0, 0.025)
               for z in (-0.05, -0.025, 0.0, 0.025, 0.05))  # markers 1-15, 25 mm pitch


def exact_detections(cam, xyz: np.ndarray) -> Detections:
    """Exact detections of the points (k, 3) m in one camera."""
    uv = cam.project(np.asarray(xyz, np.float64).reshape(-1, 3))
    return Detections(uv, np.ones(len(uv)), np.full(len(uv), 4.0))


def numbers_given(out: list[PixelFrame], camera, where: Callable[[int], np.ndarray],
                  first: int = 0) -> list[int]:
    """The number ``camera`` (a camera model with a name) gave the point ``where(k)`` (3,) m in
    each of its frames ``k`` from ``first`` on; asserts the point was detected in each."""
    frames = sorted((f for f in out if f.camera == camera.name), key=lambda f: f.stamp_s)
    got = []
    for k, f in enumerate(frames[first:], first):
        d = np.linalg.norm(f.uv - camera.project(np.asarray(where(k))[None])[0], axis=1)
        assert d.min() < 0.5  # the spot is there in every frame
        got.append(int(f.markers[int(np.argmin(d))]))
    return got


def feed_frame(tracker, cams: dict, k: int, side: list, front: list) -> list[PixelFrame]:
    """Frame ``k`` of both cameras (the side's points (n, 3) m at ``k * DT``, the front's
    ``OFFSET`` later) into ``tracker`` (a ``StereoMarkerTracker``); the frames it released."""
    tracker.update_detections('cam_side', k * DT, exact_detections(cams['cam_side'],
                                                                   np.array(side)))
    out = tracker.release()
    tracker.update_detections('cam_front', k * DT + OFFSET,
                              exact_detections(cams['cam_front'], np.array(front)))
    return out + tracker.release()


def run_scene(rig, config: StereoTrackConfig, scene: Iterable[tuple[list, list]],
              ) -> tuple[list[PixelFrame], StereoMarkerTracker]:
    """A scene given as (side points, front points) (n, 3) m per frame, fed through
    ``feed_frame`` into a ``StereoMarkerTracker`` with ``config``: every frame it released
    (``flush`` included) and the tracker. One loop for the numbering tests' scenes, which
    differ only in what each camera sees."""
    cams = {c.name: c for c in rig.cameras}
    tracker = StereoMarkerTracker(cams, config)
    out: list[PixelFrame] = []
    for k, (side, front) in enumerate(scene):
        out += feed_frame(tracker, cams, k, side, front)
    return out + tracker.flush(), tracker
