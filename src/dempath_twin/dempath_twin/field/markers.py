"""The field twin: a synthetic "measurement" of marker trajectories by the twin's two cameras.

It stands in for the paper's field recording (two GoPros, markers clicked by hand): true marker
trajectories ``(t, marker, x, y, z)`` from a DEM run with a hidden physical setting are moved
into the cameras' world frame, resampled to the cameras' 50 FPS, projected through the twin's
true cameras (``dempath_twin.rig.paper_rig``) and disturbed by clicking noise of 2.36 px (x)
and 2.75 px (y), the repeatability the paper measured (Technologies 2025, 13, 570, sec. 2.5).
:func:`field_messages` turns them into rosbag2 messages: ``dempath_msgs/PixelPoints``
(``SOURCE_CLICKED``) per camera and small JPEG previews with the marker spheres for Foxglove.

Frames: the scene frame has X = 0 on the tool axis and Z = 0 at the bin's start wall; the field
(camera) frame has its origin where the calibration board lay, which we put on the surface at
the centre of the marker grid (``FieldTwinConfig.origin_m`` in scene coordinates). The two
differ by a translation only, so scores that shift every trajectory to its start do not see it.
"""

from __future__ import annotations

import csv
import logging
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath import topics
from dempath_twin.errors import TwinError
from dempath_twin.images import jpeg_message, stamp_header

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
START_NS = 1_700_000_000_000_000_000  # fixed epoch of the first frame, so the bag is reproducible
SAND_BGR = (120.0, 170.0, 200.0)  # colour of the preview background
MARKER_BGR = (25, 30, 35)  # dark marker spheres, as painted in the paper


class MarkerTracks(NamedTuple):
    """Marker trajectories on a common time base.

    Attributes:
        times: (nt,) s.
        marker_ids: (m,) marker numbers (1-15 in the paper's grid).
        xyz: (nt, m, 3) m, NaN where a marker is missing.
    """

    times: FloatArray
    marker_ids: NDArray[np.int32]
    xyz: FloatArray


@dataclass(frozen=True)
class FieldTwinConfig:
    """How the twin records.

    Attributes:
        fps: camera frame rate [1/s] (the paper's GoPros: 50).
        sigma_px: 1-sigma clicking noise along image x and y [px] (paper: 2.36, 2.75).
        seed: seed of the clicking noise.
        image_scale: preview size relative to the 1920x1080 sensor (the pixel points stay in
            full-resolution pixels).
        jpeg_quality: JPEG quality of the previews (0-100).
        marker_radius_m: radius of the drawn marker spheres [m].
    """

    fps: float = 50.0
    sigma_px: tuple[float, float] = (2.36, 2.75)
    seed: int = 0
    image_scale: float = 0.5
    jpeg_quality: int = 70
    marker_radius_m: float = 0.006

    def __post_init__(self) -> None:
        if not 0 < self.fps <= 1000:
            msg = f'fps: must be in (0, 1000], got {self.fps!r}'
            raise ValueError(msg)
        if len(self.sigma_px) != 2 or min(self.sigma_px) < 0:
            msg = f'sigma_px: must be two values >= 0, got {self.sigma_px!r}'
            raise ValueError(msg)
        if not 0 < self.image_scale <= 1:
            msg = f'image_scale: must be in (0, 1], got {self.image_scale!r}'
            raise ValueError(msg)
        if not 0 <= self.jpeg_quality <= 100:
            msg = f'jpeg_quality: must be in 0..100, got {self.jpeg_quality!r}'
            raise ValueError(msg)


def read_marker_csv(path: str | Path) -> MarkerTracks:
    """Read measured-shape trajectories ``t,marker,x,y,z`` (s, m) into fixed-shape arrays.

    Raises:
        TwinError: missing file, wrong header or no rows.
    """
    path = Path(path)
    try:
        with path.open(newline='') as f:
            reader = csv.reader(f)
            header = next(reader, None)
            rows = [[float(v) for v in row] for row in reader if row]
    except (OSError, ValueError) as err:
        msg = f'{str(path)!r}: cannot read marker trajectories: {err}'
        raise TwinError(msg) from err
    if header != ['t', 'marker', 'x', 'y', 'z'] or not rows:
        msg = f'{str(path)!r}: expected header t,marker,x,y,z and rows, got {header!r}'
        raise TwinError(msg)
    data = np.asarray(rows)
    times, t_index = np.unique(data[:, 0], return_inverse=True)
    ids, m_index = np.unique(data[:, 1].astype(np.int32), return_inverse=True)
    xyz = np.full((len(times), len(ids), 3), np.nan)
    xyz[t_index, m_index] = data[:, 2:5]
    return MarkerTracks(times, ids.astype(np.int32), xyz)


def resample(tracks: MarkerTracks, fps: float) -> MarkerTracks:
    """Linear interpolation onto frames every 1/fps s from the first sample to the last."""
    t0, t1 = float(tracks.times[0]), float(tracks.times[-1])
    times = t0 + np.arange(int(np.floor((t1 - t0) * fps + 1e-9)) + 1) / fps
    xyz = np.empty((len(times), len(tracks.marker_ids), 3))
    for m in range(len(tracks.marker_ids)):
        for k in range(3):
            xyz[:, m, k] = np.interp(times, tracks.times, tracks.xyz[:, m, k])
    return MarkerTracks(times, tracks.marker_ids, xyz)


def grid_origin(tracks: MarkerTracks) -> FloatArray:
    """(3,) m: the field frame's origin in scene coordinates (grid centre on Y = 0)."""
    start = np.nanmean(tracks.xyz[0], axis=0)
    return np.array([start[0], 0.0, start[2]])


def shift(tracks: MarkerTracks, origin: FloatArray) -> MarkerTracks:
    """The same trajectories with ``origin`` (3,) m subtracted (scene -> field frame)."""
    return tracks._replace(xyz=tracks.xyz - np.asarray(origin, dtype=np.float64))


def project_tracks(cameras: tuple[Any, Any], xyz: FloatArray) -> FloatArray:
    """(nt, 2, m, 2) px: every marker position (nt, m, 3) m in each camera (side, front)."""
    nt, m, _ = xyz.shape
    out = np.empty((nt, len(cameras), m, 2))
    for c, cam in enumerate(cameras):
        out[:, c] = cam.project(xyz.reshape(-1, 3)).reshape(nt, m, 2)
    return out


def click_noise(uv: FloatArray, sigma_px: tuple[float, float],
                rng: np.random.Generator) -> FloatArray:
    """``uv`` (..., 2) px plus independent Gaussian noise of ``sigma_px`` along x and y."""
    return uv + rng.standard_normal(uv.shape) * np.asarray(sigma_px, dtype=np.float64)


def outside_image(cameras: tuple[Any, Any], uv: FloatArray) -> int:
    """How many projected points (nt, 2, m, 2) px fall outside their image (or are NaN)."""
    bad = 0
    for c, cam in enumerate(cameras):
        p = uv[:, c]
        inside = (p[..., 0] >= 0) & (p[..., 0] < cam.width) & (p[..., 1] >= 0) \
            & (p[..., 1] < cam.height)
        bad += int((~inside).sum())
    return bad


def background(width: int, height: int, seed: int) -> NDArray[np.uint8]:
    """A sand-coloured (BGR) preview frame with a soft gradient and seeded grain."""
    rng = np.random.default_rng(seed)
    rows = np.linspace(0.85, 1.0, height)[:, None, None]
    sand = np.array(SAND_BGR) * rows * np.ones((1, width, 1))
    grain = cv2.GaussianBlur(rng.normal(0, 6, (height, width)), (0, 0), 1.2)[..., None]
    out: NDArray[np.uint8] = np.clip(sand + grain, 0, 255).astype(np.uint8)
    return out


def render_preview(camera: Any, xyz: FloatArray, base: NDArray[np.uint8],
                   config: FieldTwinConfig) -> NDArray[np.uint8]:
    """The preview image of ``camera`` with a shaded sphere at each marker (m, 3) m, far first."""
    img = base.copy()
    depth = camera.to_camera(xyz)[:, 2]
    uv = camera.project(xyz) * config.image_scale
    radius = config.marker_radius_m * camera.K[0, 0] * config.image_scale / depth
    for i in np.argsort(-depth):
        if not np.all(np.isfinite(uv[i])):
            continue
        centre, rad = (round(uv[i, 0] * 4), round(uv[i, 1] * 4)), max(4, round(radius[i] * 4))
        cv2.circle(img, centre, rad, MARKER_BGR, -1, cv2.LINE_AA, shift=2)
        cv2.circle(img, (centre[0] - rad // 3, centre[1] - rad // 3), max(2, rad // 3),
                   (90, 95, 100), -1, cv2.LINE_AA, shift=2)
    return img


def field_messages(tracks: MarkerTracks, cameras: tuple[Any, Any], clicked: FloatArray,
                   config: FieldTwinConfig, types: Any) -> Iterator[tuple[str, str, int, Any]]:
    """Yield ``(topic, msgtype, t_ns, message)`` per frame and camera: preview JPEG, clicks.

    Args:
        tracks: true trajectories in the field frame, one row per camera frame.
        cameras: (side, front) true cameras.
        clicked: (nt, 2, m, 2) px noisy pixel points (full resolution).
        config: recording settings.
        types: the rosbags typestore's ``types`` (std_msgs, sensor_msgs, dempath_msgs).
    """
    points_t = types['dempath_msgs/msg/PixelPoints']
    size = [(round(c.width * config.image_scale), round(c.height * config.image_scale))
            for c in cameras]
    bases = [background(w, h, config.seed + i) for i, (w, h) in enumerate(size)]
    m = len(tracks.marker_ids)
    for k, t in enumerate(tracks.times - tracks.times[0]):
        t_ns = START_NS + round(float(t) * 1e9)
        for c, cam in enumerate(cameras):
            header = stamp_header(types, t_ns, cam.name)
            preview = render_preview(cam, tracks.xyz[k], bases[c], config)
            yield (topics.camera_topic(topics.IMAGE_COMPRESSED, cam.name),
                   'sensor_msgs/msg/CompressedImage', t_ns,
                   jpeg_message(types, header, preview, config.jpeg_quality, 'jpeg'))
            yield (topics.camera_topic(topics.PIXEL_POINTS, cam.name),
                   'dempath_msgs/msg/PixelPoints', t_ns,
                   points_t(header=header, marker_ids=tracks.marker_ids.astype(np.int32),
                            u=clicked[k, c, :, 0].copy(), v=clicked[k, c, :, 1].copy(),
                            confidence=np.ones(m, np.float32),
                            source=np.ones(m, np.uint8)))  # SOURCE_CLICKED


def write_truth_csv(path: str | Path, tracks: MarkerTracks) -> Path:
    """Write ``t,marker,x,y,z`` (t from the first frame [s], positions [m]) and return the path."""
    path = Path(path)
    with path.open('w', newline='') as f:
        writer = csv.writer(f)
        writer.writerow(['t', 'marker', 'x', 'y', 'z'])
        t0 = tracks.times[0]
        for k, t in enumerate(tracks.times):
            for m, marker in enumerate(tracks.marker_ids):
                writer.writerow([f'{t - t0:.4f}', int(marker),
                                 *(f'{v:.6f}' for v in tracks.xyz[k, m])])
    return path
