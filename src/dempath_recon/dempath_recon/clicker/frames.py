"""The frames a clicker session shows: camera images of a bag or of a folder, by frame index.

A bag gives every ``sensor_msgs/CompressedImage`` (preferred) or ``sensor_msgs/Image`` topic; the
camera is the topic's first name (``/cam_side/image_raw/compressed`` -> ``cam_side``). Frame k is
the first camera's k-th image and, from each other camera, the image nearest in stamp within half
a frame period (unsynchronised cameras are a few ms apart; a camera that dropped that frame shows
none). A folder holds one sub-folder of images per camera (``cam_side/``, ``cam_front/``), paired
by sorted name, or the images of a single camera; its stamps are ``k / fps``.

Only the first camera pairs the frames, so frame indices are stable for a given source: the CSV
of a session reopens on the same frames. Images of one camera must all have one size (a click's
pixel means nothing otherwise): a folder of mixed sizes is refused with the odd file named.
"""

from __future__ import annotations

import io
import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray
from PIL import Image, UnidentifiedImageError

from dempath import topics
from dempath.bagio import open_bag
from dempath.errors import BagError
from dempath_recon.errors import ClickError

LOG = logging.getLogger(__name__)
COMPRESSED, RAW = 'sensor_msgs/msg/CompressedImage', 'sensor_msgs/msg/Image'
IMAGE_SUFFIXES = ('.jpg', '.jpeg', '.png', '.bmp', '.tif', '.tiff')
BROWSER_TYPES = {'.jpg': 'image/jpeg', '.jpeg': 'image/jpeg', '.png': 'image/png'}


@dataclass(frozen=True)
class FrameImage:
    """One camera image as the browser gets it: encoded bytes, MIME type, stamp [s]."""

    data: bytes
    mime: str
    stamp_s: float


@dataclass
class FrameSet:
    """The frames of a session.

    Attributes:
        source: The bag or folder.
        cameras: Camera names, the paper's order first (cam_side, cam_front).
        sizes: (width, height) [px] per camera.
        frames: Per frame index, the image of each camera (None where it has none).
        warnings: Things the user must know (e.g. only one camera).
    """

    source: Path
    cameras: tuple[str, ...]
    sizes: dict[str, tuple[int, int]]
    frames: list[dict[str, FrameImage | None]]
    warnings: list[str] = field(default_factory=list)


def camera_order(names: Sequence[str]) -> tuple[str, ...]:
    """The paper's cameras first (side, front), then the others by name."""
    known = [c for c in topics.CAMERAS if c in names]
    return tuple(known + sorted(set(names) - set(known)))


def image_size(data: bytes, name: str) -> tuple[int, int]:
    """(width, height) [px] from an encoded image's header.

    Raises:
        ClickError: Not a readable image.
    """
    try:
        with Image.open(io.BytesIO(data)) as img:
            return int(img.width), int(img.height)
    except (UnidentifiedImageError, OSError) as err:
        msg = f'{name}: not a readable image ({err})'
        raise ClickError(msg) from err


def raw_to_png(msg: object, name: str) -> bytes:
    """A sensor_msgs/Image (mono8, bgr8, rgb8, mono16) as PNG bytes (lossless).

    Raises:
        ClickError: An encoding the clicker does not show.
    """
    encoding = str(getattr(msg, 'encoding', ''))
    height, width = int(getattr(msg, 'height', 0)), int(getattr(msg, 'width', 0))
    data = np.asarray(getattr(msg, 'data', b''), np.uint8)
    channels = {'mono8': 1, 'bgr8': 3, 'rgb8': 3, 'mono16': 2}.get(encoding)
    if channels is None or data.size < height * width * channels:
        msg_ = f'{name}: image encoding {encoding!r} ({width}x{height}) cannot be shown'
        raise ClickError(msg_)
    rows = data[:height * int(getattr(msg, 'step', width * channels))].reshape(height, -1)
    pixels = rows[:, :width * channels]
    img: NDArray[np.generic] = pixels.view(np.uint16).reshape(height, width) \
        if encoding == 'mono16' else pixels.reshape(height, width, -1)
    if encoding == 'rgb8':
        img = img[..., ::-1]
    ok, png = cv2.imencode('.png', np.ascontiguousarray(img))
    return bytes(png) if ok else b''


def _bag_images(path: Path) -> dict[str, list[FrameImage]]:
    """Every camera's images of a bag in stamp order (compressed topics preferred)."""
    try:
        bag = open_bag(path)
    except BagError as err:
        raise ClickError(str(err)) from err
    with bag:
        chosen: dict[str, str] = {}
        for info in sorted(bag.topics.values(), key=lambda t: t.msgtype != COMPRESSED):
            camera = info.name.strip('/').split('/')[0]
            if info.msgtype in (COMPRESSED, RAW) and camera not in chosen:
                chosen[camera] = info.name
        images: dict[str, list[FrameImage]] = {c: [] for c in chosen}
        by_topic = {t: c for c, t in chosen.items()}
        try:
            for raw in bag.messages(list(chosen.values())):
                msg = bag.deserialize(raw)
                stamp = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
                if raw.msgtype == COMPRESSED:
                    kind = 'image/png' if 'png' in msg.format.lower() else 'image/jpeg'
                    image = FrameImage(bytes(msg.data), kind, stamp)
                else:
                    image = FrameImage(raw_to_png(msg, f'{path}:{raw.topic}'), 'image/png', stamp)
                images[by_topic[raw.topic]].append(image)
        except BagError as err:
            raise ClickError(str(err)) from err
    return {c: sorted(v, key=lambda im: im.stamp_s) for c, v in images.items() if v}


def _folder_images(path: Path, fps: float) -> dict[str, list[tuple[Path, FrameImage]]]:
    """Images per camera sub-folder (or the folder itself as one camera), by sorted name."""
    def images_in(folder: Path) -> list[Path]:
        return sorted(p for p in folder.iterdir()
                      if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)

    subs = {d.name: images_in(d) for d in sorted(path.iterdir()) if d.is_dir()}
    subs = {name: files for name, files in subs.items() if files}
    if not subs:
        subs = {path.resolve().name: images_in(path)} if images_in(path) else {}
    out: dict[str, list[tuple[Path, FrameImage]]] = {}
    for camera, files in subs.items():
        out[camera] = [(f, FrameImage(_read(f), BROWSER_TYPES.get(f.suffix.lower(), 'image/png'),
                                      k / fps)) for k, f in enumerate(files)]
    return out


def _read(path: Path) -> bytes:
    """The file's bytes; formats a browser cannot show (bmp, tif) are re-encoded as PNG."""
    data = path.read_bytes()
    if path.suffix.lower() in BROWSER_TYPES:
        return data
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    ok, png = cv2.imencode('.png', img) if img is not None else (False, None)
    if not ok or png is None:
        msg = f'{path}: not a readable image'
        raise ClickError(msg)
    return bytes(png)


def _check_sizes(camera: str, named: Sequence[tuple[str, FrameImage]]) -> tuple[int, int]:
    """The one image size of a camera.

    Raises:
        ClickError: ``<file>: W1xH1 px, but the other images of <camera> are W0xH0 px``.
    """
    first_name, first = named[0]
    size = image_size(first.data, first_name)
    for name, image in named[1:]:
        other = image_size(image.data, name)
        if other != size:
            msg = (f'{name}: {other[0]}x{other[1]} px, but the other images of {camera} are '
                   f'{size[0]}x{size[1]} px (a session needs one size per camera)')
            raise ClickError(msg)
    return size


def _pair(images: dict[str, list[FrameImage]], by_stamp: bool) -> list[dict[str, FrameImage
                                                                           | None]]:
    """Frame k: the first camera's k-th image and each other camera's partner (or None)."""
    cameras = list(images)
    ref = images[cameras[0]]
    ref_t = np.array([im.stamp_s for im in ref])
    half_period = 0.5 * float(np.median(np.diff(ref_t))) if len(ref_t) > 1 else np.inf
    frames: list[dict[str, FrameImage | None]] = [{cameras[0]: im} for im in ref]
    for camera in cameras[1:]:
        for k, frame in enumerate(frames):
            others = images[camera]
            if not by_stamp:
                frame[camera] = others[k] if k < len(others) else None
                continue
            t = np.array([im.stamp_s for im in others])
            j = int(np.argmin(np.abs(t - ref_t[k])))
            frame[camera] = others[j] if abs(t[j] - ref_t[k]) <= half_period else None
    return frames


def open_frames(source: str | Path, fps: float = 50.0) -> FrameSet:
    """Open a bag or a folder of images for clicking.

    Args:
        source: A rosbag2 bag (folder with metadata.yaml, or .mcap/.db3) or a folder of images.
        fps: Frame rate of a folder's images, for their stamps [1/s].

    Raises:
        ClickError: No images, unreadable images, mixed sizes within a camera.
    """
    path = Path(source)
    is_bag = path.is_file() or (path / 'metadata.yaml').is_file()
    if not path.exists():
        msg = f'{path}: no such bag or folder of images'
        raise ClickError(msg)
    if is_bag:
        images = _bag_images(path)
        named = {c: [(f'{path}:{c} image {k}', im) for k, im in enumerate(v)]
                 for c, v in images.items()}
    else:
        files = _folder_images(path, fps)
        images = {c: [im for _, im in v] for c, v in files.items()}
        named = {c: [(str(f), im) for f, im in v] for c, v in files.items()}
    if not images:
        what = 'no CompressedImage or Image topic' if is_bag else 'no images (.jpg, .png, ...)'
        msg = f'{path}: {what}'
        raise ClickError(msg)
    order = camera_order(list(images))
    images = {c: images[c] for c in order}
    sizes = {c: _check_sizes(c, named[c]) for c in order}
    result = FrameSet(path, order, sizes, _pair(images, by_stamp=is_bag))
    if len(order) == 1:
        result.warnings.append(
            f'{path}: only one camera ({order[0]}): its clicks are saved, but 3D needs both')
    LOG.info('%s: %d frames of %s', path, len(result.frames), ', '.join(order))
    return result
