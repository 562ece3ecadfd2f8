"""A rendered field recording: what the paper's two GoPros saw of a dempath_sim run, as a bag.

The recording starts with a calibration segment (the ChArUco board moved through the shared
view, rendered by the calibration twin's board renderer), then every camera frame of the run:
the whole bed rendered from the run's snapshots (``camera_frame``), markers as 8 mm clay
spheres riding on their particles, the steel tool, changing light, motion blur, noise and JPEG.
The two cameras are not synchronised: the front camera exposes ``front_offset_s`` after the side
one, and each stamps its frames with its own clock. The bag (rosbag2 MCAP) holds per camera
``sensor_msgs/CompressedImage`` (JPEG, bgr8) and ``sensor_msgs/CameraInfo`` (the rig's nominal
intrinsics); the ground truth goes to ``<bag>.truth.json`` beside it and never into the bag.

Frames: the run's scene frame (X = 0 on the tool axis, Z from the bin's start wall) is moved to
the cameras' field frame by subtracting the marker grid's centre on the surface (as the
clicked field twin does).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_twin.render.bed_source import BedRecord
from dempath_twin.render.camera_frame import (
    FieldCamera,
    Light,
    Look,
    Scene3D,
    ShadowMap,
    scaled_camera,
)

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
START_NS = 1_700_000_000_000_000_000  # fixed epoch of the first frame: reproducible bags
CALIB_GAP_S = 1.0  # pause between the calibration segment and the run [s]


@dataclass(frozen=True)
class RecordingConfig:
    """How the field recording is made.

    Attributes:
        fps: camera frame rate [1/s] (the paper's GoPros: 50).
        front_offset_s: the front camera exposes and stamps this much later than the side [s].
        scale: sensor size relative to 1920x1080 (smaller bags, tests).
        jpeg_quality: JPEG quality of the frames (0-100).
        calib_views: board views of the calibration segment (0 = none).
        calib_period_s: time between calibration views [s].
        max_frames: render at most this many run frames (None: all).
        start_s: run time of the first frame [s] (skip the run's quiet start).
        seed: seed of every random draw (grain colours, light, noise).
        look: appearance settings.
    """

    fps: float = 50.0
    front_offset_s: float = 0.003
    scale: float = 1.0
    jpeg_quality: int = 85
    calib_views: int = 12
    calib_period_s: float = 0.2
    max_frames: int | None = None
    start_s: float = 0.0
    seed: int = 0
    look: Look = field(default_factory=Look)

    def __post_init__(self) -> None:
        if not 0 < self.fps <= 240:
            raise ValueError(f'fps: must be in (0, 240], got {self.fps!r}')
        if not 0 <= abs(self.front_offset_s) < 1.0 / self.fps:
            msg = f'front_offset_s: must be below one frame period, got {self.front_offset_s!r}'
            raise ValueError(msg)
        if not 0.05 <= self.scale <= 1:
            raise ValueError(f'scale: must be in [0.05, 1], got {self.scale!r}')
        if not 1 <= self.jpeg_quality <= 100:
            raise ValueError(f'jpeg_quality: must be in 1..100, got {self.jpeg_quality!r}')


@dataclass
class FrameTruth:
    """Truth of one camera frame: stamp, marker pixel centres, visibility, 3D centres."""

    camera: str
    stamp_ns: int
    uv: FloatArray  # (m, 2) px, projected marker centres (OpenCV pixel-centre convention)
    visible: FloatArray  # (m,) share of the marker's disc not hidden, 0 outside the image
    xyz: FloatArray  # (m, 3) m, marker sphere centres in the field frame


def grid_origin(bed: BedRecord) -> FloatArray:
    """(3,) m: the field frame's origin in scene coordinates (marker grid centre, Y = 0)."""
    start = np.nanmean(bed.positions[0, bed.marker_index].astype(np.float64), axis=0)
    return np.array([start[0], 0.0, start[2]])


class FieldScene:
    """The bed of a run as the cameras see it: field frame, grain colours, marker spheres.

    Args:
        bed: the run's bed record.
        look: appearance (marker diameter and colour, sand colour, grain spread).
        rng: draws the grains' colours and texture phases.
    """

    def __init__(self, bed: BedRecord, look: Look, rng: np.random.Generator) -> None:
        self.bed, self.origin = bed, grid_origin(bed)
        n = len(bed.radii)
        tone = 1.0 + look.grain_spread * rng.standard_normal((n, 1))
        hue = 1.0 + 0.04 * rng.standard_normal((n, 3))
        self.albedo = np.clip(np.array(look.sand_bgr) * tone * hue, 0.05, 0.95).astype(np.float32)
        self.albedo[bed.marker_index] = look.marker_bgr
        self.texture = rng.uniform(0, 2 * np.pi, n).astype(np.float32)
        self.radii = bed.radii.copy()
        r_marker = 0.5 * look.marker_diameter_m
        self.lift = np.maximum(bed.radii[bed.marker_index] - r_marker, 0.0)
        self.radii[bed.marker_index] = r_marker

    def at(self, t: float) -> Scene3D:
        """Spheres and tool at time ``t`` [s] in the field frame."""
        centres = self.bed.at(t).astype(np.float64) - self.origin
        centres[self.bed.marker_index, 1] += self.lift  # clay sphere's top flush with its grain
        tool = self.bed.tool_mesh + (self.bed.tool_at(t) - self.origin)
        return Scene3D(centres, self.radii, self.albedo, self.texture, tool)

    def markers(self, t: float) -> FloatArray:
        """(m, 3) marker sphere centres at ``t`` [m], field frame."""
        return np.asarray(self.at(t).centres[self.bed.marker_index], np.float64)


def light_change(times: FloatArray, flicker: float, cloud: float, seed: int) -> FloatArray:
    """(n,) the light's relative level at each frame time ``times`` (n,) [s]: ``1 + flicker
    u`` (``u`` uniform in [-1, 1], drawn from ``seed``'s own generator so a render without it
    keeps its noise) times a cloud's dip, a raised cosine from 1 at the first and last frame
    to ``cloud`` at the middle (``Look.flicker``, ``Look.cloud``)."""
    n = len(times)
    level = np.ones(n)
    if flicker > 0:
        level *= 1.0 + flicker * np.random.default_rng([seed, 7]).uniform(-1.0, 1.0, n)
    if cloud < 1 and n > 1:
        span = max(float(times[-1] - times[0]), 1e-9)
        phase = (np.asarray(times, np.float64) - times[0]) / span  # 0..1 over the pass
        level *= 1.0 - (1.0 - cloud) * 0.5 * (1.0 - np.cos(2 * np.pi * phase))
    return level


def lighting(times: FloatArray, rng: np.random.Generator,
             level: FloatArray | None = None) -> list[Light]:
    """A light that changes over the recording: the sun's azimuth drifts, clouds dim it;
    ``level`` (n,) scales each frame's gain (:func:`light_change`; None: 1)."""
    az0, drift = rng.uniform(0, 2 * np.pi), rng.uniform(0.2, 0.4)
    period, phase = rng.uniform(0.8, 1.6), rng.uniform(0, 2 * np.pi)
    span = max(float(times[-1] - times[0]), 1e-9)
    out = []
    scale = np.ones(len(times)) if level is None else np.asarray(level, np.float64)
    for t, k in zip(times, scale, strict=True):
        az = az0 + drift * (t - times[0]) / span
        elev = np.radians(50.0)
        direction = (float(np.cos(elev) * np.cos(az)), float(np.sin(elev)),
                     float(np.cos(elev) * np.sin(az)))
        gain = (1.0 + 0.12 * np.sin(2 * np.pi * t / period + phase)) * k
        grad = (0.2 * np.sin(az), 0.15 * np.cos(az))
        out.append(Light(direction, float(gain), (float(grad[0]), float(grad[1]))))
    return out


def render_frame(camera: FieldCamera, scene: FieldScene, t: float, light: Light,
                 rng: np.random.Generator) -> tuple[NDArray[np.uint8], FrameTruth]:
    """One exposure of ``camera`` centred on ``t`` [s]: the BGR image and its truth."""
    look = camera.look
    n = look.blur_subframes
    subs = [t] if n == 1 else [t + look.exposure_s * (k / (n - 1) - 0.5) for k in range(n)]
    acc: NDArray[np.float32] | None = None
    visible = np.zeros(len(scene.bed.marker_index))
    for ts in subs:
        s3d = scene.at(ts)
        ideal, ibuf = camera.radiance(s3d, light, ShadowMap(s3d, light.direction))
        acc = ideal if acc is None else acc + ideal
        visible += camera.visible_fraction(ibuf, s3d, scene.bed.marker_index) / n
    assert acc is not None
    image = camera.expose(np.asarray(acc / n, np.float32), light, rng)
    xyz = scene.markers(t)
    uv = camera.camera.project(xyz)
    cam = camera.camera
    inside = (uv[:, 0] >= 0) & (uv[:, 0] <= cam.width - 1) & (uv[:, 1] >= 0) \
        & (uv[:, 1] <= cam.height - 1)
    return image, FrameTruth(cam.name, 0, uv, np.where(inside, visible, 0.0), xyz)


def frame_times(bed: BedRecord, config: RecordingConfig) -> FloatArray:
    """(nf,) exposure times of the side camera [s] inside the run (front: + offset)."""
    end = float(bed.times[-1]) - max(config.front_offset_s, 0) - config.look.exposure_s
    n = max(int(np.floor((end - config.start_s) * config.fps + 1e-9)) + 1, 0)
    if config.max_frames is not None:
        n = min(n, config.max_frames)
    return np.asarray(config.start_s + np.arange(n) / config.fps + 0.5 * config.look.exposure_s)


def cameras_for(rig: Any, config: RecordingConfig) -> tuple[Any, Any]:
    """The rig's two cameras at the recording's sensor scale."""
    cams = rig.cameras
    if config.scale != 1.0:
        cams = tuple(scaled_camera(c, config.scale) for c in cams)
    return cams[0], cams[1]


def field_frames(bed: BedRecord, rig: Any, config: RecordingConfig, t0_s: float,
                 truth: list[FrameTruth]) -> Iterator[tuple[str, NDArray[np.uint8], int]]:
    """Yield ``(camera name, BGR image, stamp ns)`` of the run, appending each frame's truth."""
    rng = np.random.default_rng(config.seed)
    scene = FieldScene(bed, config.look, rng)
    cams = [FieldCamera(c, config.look, seed=config.seed + i)
            for i, c in enumerate(cameras_for(rig, config))]
    times = frame_times(bed, config)
    look = config.look
    lights = lighting(times, rng, light_change(times, look.flicker, look.cloud, config.seed))
    for k, t in enumerate(times):
        for c, cam in enumerate(cams):
            offset = config.front_offset_s if c == 1 else 0.0
            image, ft = render_frame(cam, scene, float(t) + offset, lights[k], rng)
            ft.stamp_ns = START_NS + round((t0_s + t + offset) * 1e9)
            truth.append(ft)
            yield cam.camera.name, image, ft.stamp_ns
        LOG.info('rendered frame %d/%d', k + 1, len(times))


def truth_json(truth: list[FrameTruth], bed: BedRecord, scene_origin: FloatArray, rig: Any,
               config: RecordingConfig, calib: dict[str, Any]) -> dict[str, Any]:
    """The JSON-ready ground truth of a recording."""
    return {
        'synthetic': True,
        'what': 'rendered field recording of a dempath_sim run seen by the twin rig',
        'run': {k: bed.meta.get(k) for k in ('run_id', 'scene', 'seed', 'effects')},
        'field_origin_in_scene_m': scene_origin.tolist(),
        'frame': 'field = scene - field_origin_in_scene_m (X lateral, Y up, Z travel) [m]',
        'pixel_convention': 'OpenCV: integer coordinates at pixel centres',
        'config': {**asdict(config)},
        'cameras': [c.to_dict() for c in cameras_for(rig, config)],
        'marker_ids': bed.marker_ids.tolist(),
        'marker_grid_m': _grid_layout(bed, scene_origin),
        'calibration_segment': calib,
        'frames': [{'camera': f.camera, 'stamp_ns': f.stamp_ns,
                    'uv': np.round(f.uv, 4).tolist(), 'visible': np.round(f.visible, 4).tolist(),
                    'xyz': np.round(f.xyz, 6).tolist()} for f in truth],
    }


def _grid_layout(bed: BedRecord, origin: FloatArray) -> list[list[float]]:
    """The scene's nominal marker grid points in the field frame (the experiment's set-up,
    known to the experimenter; not a measured position), markers 1..n in order."""
    grid = np.asarray(bed.meta.get('grid_points', []), np.float64).reshape(-1, 3) - origin
    grid[:, 1] = 0.0  # laid on a nominally flat surface
    out: list[list[float]] = np.round(grid, 6).tolist()
    return out


def truth_path(bag: Path) -> Path:
    """``<bag>.truth.json`` beside the bag folder."""
    return bag.with_name(bag.name + '.truth.json')


def save_truth(bag: Path, data: dict[str, Any]) -> Path:
    """Write the truth JSON beside ``bag``."""
    path = truth_path(bag)
    path.write_text(json.dumps(data))
    return path
