"""Which markers a rig's two cameras can see, and when: coverage without rendering the images.

A marker can be triangulated in a frame only when both cameras see it: at least half of its
disc visible (the detector's recall on such markers is 99 %, bench/detect_track.py). No camera
can see a marker the tool's heave has buried, so a marker is scored over the frames in which it
is *on the surface*: at least half its disc seen from straight above (a distant overhead view
of the grains alone, the tool left out so that the shank does not hide markers beside it). The
share of those frames in which both cameras see it is the marker's coverage; a marker covered
in at least 80 % of them counts as reconstructed (issue 26 asks for 13 of 15 on the bundled
field twin). Visibility is computed exactly as the renderer's truth computes it (the same
z-buffer of every sphere and the tool, the same exposure sub-frames) but without shading,
shadows or JPEG, so a rig placement can be judged on a run in seconds per frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_twin.render.bed_source import BedRecord
from dempath_twin.render.camera_frame import FieldCamera, Look, Scene3D
from dempath_twin.render.recording import FieldScene, RecordingConfig, cameras_for, frame_times

VISIBLE = 0.5  # visible fraction of a marker's disc for a detection
COVERED = 0.8  # share of the on-surface frames a reconstructed marker needs
OVERHEAD_HEIGHT_M = 1.5  # the overhead view's height above the grid centre
OVERHEAD_FOCAL_PX = 2500.0  # its focal length: a 0.65 x 1.15 m footprint, markers ~7 px across


@dataclass(frozen=True)
class Coverage:
    """Per marker, the share of frames seen by each camera and by both.

    Attributes:
        frames: Frames per camera.
        markers: Marker numbers.
        per_camera: {camera name: (m,) share of all frames it sees each marker}.
        both: (m,) share of the marker's on-surface frames in which both cameras see it.
        on_surface: (m,) share of all frames in which the marker is on the surface (all ones
            when the source does not say: every frame counts).
    """

    frames: int
    markers: tuple[int, ...]
    per_camera: dict[str, NDArray[np.float64]]
    both: NDArray[np.float64]
    on_surface: NDArray[np.float64]

    @property
    def reconstructed(self) -> list[int]:
        """Markers both cameras see in at least ``COVERED`` of the frames."""
        return [m for m, b in zip(self.markers, self.both, strict=True) if b >= COVERED]

    def to_json(self) -> dict[str, Any]:
        """The figures, JSON-ready (shares rounded to 0.001)."""
        rows = {str(m): {**{c: round(float(v[j]), 3) for c, v in self.per_camera.items()},
                         'on_surface': round(float(self.on_surface[j]), 3),
                         'both': round(float(self.both[j]), 3)}
                for j, m in enumerate(self.markers)}
        return {'frames': self.frames, 'markers': len(self.markers),
                'markers_reconstructed': len(self.reconstructed),
                'reconstructed': self.reconstructed, 'per_marker': rows}


def coverage_of(visible: dict[str, NDArray[np.float64]], markers: list[int],
                surface: NDArray[np.bool_] | None = None) -> Coverage:
    """Coverage from per-camera visible fractions, each (frames, m) in frame order, scored
    over the frames in which each marker is on the surface (``surface``: (frames, m) bool;
    None: every frame)."""
    cams = sorted(visible)
    n = min(len(v) for v in visible.values())
    seen = {c: np.asarray(visible[c][:n]) >= VISIBLE for c in cams}
    both = np.logical_and.reduce([seen[c] for c in cams])
    up = np.ones_like(both) if surface is None else np.asarray(surface[:n], bool)
    share = (both & up).sum(0) / np.maximum(up.sum(0), 1)
    return Coverage(n, tuple(int(m) for m in markers),
                    {c: seen[c].mean(0) for c in cams}, share, up.mean(0))


def truth_coverage(truth: dict[str, Any]) -> Coverage:
    """Coverage of a rendered recording from its truth file (``<bag>.truth.json``; one made
    before the truth said which markers were on the surface counts every frame)."""
    by_cam: dict[str, list[Any]] = {}
    for frame in truth['frames']:
        by_cam.setdefault(frame['camera'], []).append(frame['visible'])
    surface = truth.get('on_surface')
    return coverage_of({c: np.asarray(v, np.float64) for c, v in by_cam.items()},
                       [int(m) for m in truth['marker_ids']],
                       None if surface is None else np.asarray(surface, bool))


def overhead_camera() -> Any:
    """A distortion-free camera straight above the grid centre, image-up along +Z."""
    from dempath_calib.camera import CameraModel
    from dempath_twin.rig import IMAGE_SIZE, look_at

    rot, t = look_at(np.array([0.0, OVERHEAD_HEIGHT_M, 0.0]), np.zeros(3),
                     np.array([0.0, 0.0, 1.0]))
    w, h = IMAGE_SIZE
    k = np.array([[OVERHEAD_FOCAL_PX, 0.0, w / 2.0], [0.0, OVERHEAD_FOCAL_PX, h / 2.0],
                  [0.0, 0.0, 1.0]])
    return CameraModel('overhead', w, h, k, np.zeros(5), rot, t)


def on_surface(bed: BedRecord, config: RecordingConfig) -> NDArray[np.bool_]:
    """(frames, m): whether each marker is on the surface at the recording's frame times (at
    least half its disc seen from straight above, the grains alone)."""
    scene = FieldScene(bed, config.look, np.random.default_rng(config.seed))
    cam = FieldCamera(overhead_camera(), Look(blur_subframes=1, supersample=1))
    rows = []
    for t in frame_times(bed, config):
        s3d = scene.at(float(t))
        grains = Scene3D(s3d.centres, s3d.radii, s3d.albedo, s3d.texture, s3d.tool[:0])
        _, ibuf, _ = cam.buffers(grains)
        rows.append(cam.visible_fraction(ibuf, grains, bed.marker_index) >= VISIBLE)
    return np.asarray(rows, bool)


def rig_coverage(bed: BedRecord, rig: Any, config: RecordingConfig) -> Coverage:
    """Coverage of ``bed`` seen through ``rig`` at the recording's frame times (no images)."""
    scene = FieldScene(bed, config.look, np.random.default_rng(config.seed))
    look = config.look
    n = look.blur_subframes
    visible: dict[str, NDArray[np.float64]] = {}
    for c, cam in enumerate(cameras_for(rig, config)):
        field_cam = FieldCamera(cam, look, seed=config.seed + c)
        offset = config.front_offset_s if c == 1 else 0.0
        rows: list[NDArray[np.float64]] = []
        for t in frame_times(bed, config):
            t0 = float(t) + offset
            subs = [t0] if n == 1 else [t0 + look.exposure_s * (k / (n - 1) - 0.5)
                                        for k in range(n)]
            acc = np.zeros(len(bed.marker_index))
            for ts in subs:
                s3d = scene.at(ts)
                _, ibuf, _ = field_cam.buffers(s3d)
                acc += field_cam.visible_fraction(ibuf, s3d, bed.marker_index) / n
            uv = cam.project(scene.markers(t0))
            inside = (uv[:, 0] >= 0) & (uv[:, 0] <= cam.width - 1) & (uv[:, 1] >= 0) \
                & (uv[:, 1] <= cam.height - 1)
            rows.append(np.where(inside, acc, 0.0))
        visible[cam.name] = np.asarray(rows)
    return coverage_of(visible, [int(m) for m in bed.marker_ids], on_surface(bed, config))
