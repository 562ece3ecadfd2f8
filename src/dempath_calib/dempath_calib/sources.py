"""Calibration inputs: a rosbag2 bag, a folder of frames, or one video file per camera.

Each source yields ``(camera, stamp_s, image)`` with camera 0 = side and 1 = front, one image
at a time (nothing is held in memory). Stamps: the header stamp for bags; for videos the
container's frame time (or a timestamps CSV); for folders a ``stamps.csv`` (``file,stamp_s``)
or frame index / fps. Unsynchronised cameras are paired later by ``pairing.pair_frames``.
"""

from __future__ import annotations

import csv
import logging
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath import topics
from dempath.bagio import open_bag
from dempath.errors import BagError
from dempath_calib.errors import InputSourceError

LOG = logging.getLogger(__name__)
Frame = tuple[int, float, NDArray[np.uint8]]
IMAGE_SUFFIXES = ('.png', '.jpg', '.jpeg', '.bmp', '.tif', '.tiff')
VIDEO_SUFFIXES = ('.mp4', '.avi', '.mov', '.mkv')


def decode_image(msgtype: str, msg: object, where: str) -> NDArray[np.uint8]:
    """Grey (h, w) uint8 image of a sensor_msgs Image or CompressedImage (rosbags object)."""
    data = np.asarray(msg.data, dtype=np.uint8)  # type: ignore[attr-defined]
    if msgtype.endswith('CompressedImage'):
        img = cv2.imdecode(data, cv2.IMREAD_GRAYSCALE)
        if img is None:
            msg_ = f'{where}: cannot decode compressed image ({msg.format!r})'  # type: ignore[attr-defined]
            raise InputSourceError(msg_)
        return np.asarray(img, np.uint8)
    enc = str(msg.encoding).lower()  # type: ignore[attr-defined]
    h, w, step = int(msg.height), int(msg.width), int(msg.step)  # type: ignore[attr-defined]
    channels = {'mono8': 1, '8uc1': 1, 'bgr8': 3, 'rgb8': 3, 'bgra8': 4, 'rgba8': 4}.get(enc)
    if channels is None or data.size < h * step:
        msg_ = f'{where}: unsupported image encoding {enc!r} or short data'
        raise InputSourceError(msg_)
    img = data[:h * step].reshape(h, step)[:, :w * channels].reshape(h, w, channels)
    if channels == 1:
        return np.ascontiguousarray(img[..., 0])
    code = {('bgr8', 3): cv2.COLOR_BGR2GRAY, ('rgb8', 3): cv2.COLOR_RGB2GRAY,
            ('bgra8', 4): cv2.COLOR_BGRA2GRAY, ('rgba8', 4): cv2.COLOR_RGBA2GRAY}[(enc, channels)]
    return np.asarray(cv2.cvtColor(np.ascontiguousarray(img), code), np.uint8)


@dataclass(frozen=True)
class BagSource:
    """Both cameras' image topics of a bag (compressed preferred when both exist).

    A frame that cannot be decoded (a damaged JPEG) is named in a warning (topic, stamp, index
    on its topic), listed in ``undecodable`` and skipped, and the rest of the bag is used; only
    a bag none of whose images decodes is an error.
    """

    path: Path
    cameras: tuple[str, str] = topics.CAMERAS
    undecodable: list[str] = field(default_factory=list, compare=False, hash=False)

    def topics(self) -> list[str]:
        """The two image topics used, side first."""
        with open_bag(self.path) as bag:
            have = set(bag.topics)
        chosen = []
        for cam in self.cameras:
            options = [topics.camera_topic(topics.IMAGE_COMPRESSED, cam),
                       topics.camera_topic(topics.IMAGE_RAW, cam)]
            found = [t for t in options if t in have]
            if not found:
                msg = f'{self.path}: no image topic for {cam} (looked for {", ".join(options)})'
                raise InputSourceError(msg)
            chosen.append(found[0])
        return chosen

    def count(self) -> int:
        """Number of images."""
        names = self.topics()
        with open_bag(self.path) as bag:
            return sum(int(bag.topics[t][2]) for t in names)  # TopicInfo field 2: count

    def frames(self) -> Iterator[Frame]:
        """Yield ``(camera, stamp_s, grey image)`` in bag order."""
        names = self.topics()
        index = dict.fromkeys(names, -1)
        decoded = 0
        try:
            with open_bag(self.path, names) as bag:
                for raw in bag.messages(names):
                    msg = bag.deserialize(raw)
                    stamp = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
                    stamp = stamp or raw.log_time_ns * 1e-9
                    index[raw.topic] += 1
                    where = f'{self.path}:{raw.topic} image {index[raw.topic]} at {stamp:.6f} s'
                    try:
                        image = decode_image(raw.msgtype, msg, where)
                    except InputSourceError as err:
                        self.undecodable.append(str(err))
                        LOG.warning('%s; skipped (%d undecodable so far)', err,
                                    len(self.undecodable))
                        continue
                    decoded += 1
                    yield names.index(raw.topic), stamp, image
        except BagError as err:
            raise InputSourceError(str(err)) from err
        if self.undecodable and not decoded:
            msg = (f'{self.path}: none of its {len(self.undecodable)} images can be decoded '
                   f'(first: {self.undecodable[0]})')
            raise InputSourceError(msg)


@dataclass(frozen=True)
class VideoSource:
    """One video file per camera; stamps from the container or a timestamps CSV.

    Attributes:
        paths: (side, front) video files.
        stamps: optional per-camera frame times [s] (e.g. from ``read_timestamps_csv``).
    """

    paths: tuple[Path, Path]
    stamps: tuple[list[float], list[float]] | None = None

    def count(self) -> int:
        """Number of frames (from the container)."""
        total = 0
        for p in self.paths:
            cap = _open_video(p)
            total += int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
            cap.release()
        return total

    def frames(self) -> Iterator[Frame]:
        """Yield the side video's frames, then the front video's."""
        for cam, path in enumerate(self.paths):
            cap = _open_video(path)
            fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
            i = 0
            while True:
                ok, img = cap.read()
                if not ok:
                    break
                if self.stamps is not None:
                    if i >= len(self.stamps[cam]):
                        break
                    stamp = self.stamps[cam][i]
                else:
                    stamp = i / fps
                yield cam, stamp, np.asarray(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY), np.uint8)
                i += 1
            cap.release()
            if i == 0:
                msg = f'{path}: no frame could be decoded'
                raise InputSourceError(msg)


def _open_video(path: Path) -> cv2.VideoCapture:
    if not path.is_file():
        msg = f'{path}: video file not found'
        raise InputSourceError(msg)
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        msg = f'{path}: cannot open video'
        raise InputSourceError(msg)
    return cap


def read_timestamps_csv(path: Path) -> tuple[list[float], list[float]]:
    """Per-camera frame times from a CSV with columns ``cam_id, frame_time`` (Caliscope's).

    Camera id 0 is the side camera and 1 the front; rows of a camera are taken in time order.
    """
    try:
        with path.open() as f:
            rows = list(csv.DictReader(f))
        out: tuple[list[float], list[float]] = ([], [])
        for row in rows:
            out[int(row['cam_id'])].append(float(row['frame_time']))
    except (OSError, KeyError, ValueError, IndexError) as err:
        msg = f'{path}: not a timestamps CSV with cam_id and frame_time columns ({err})'
        raise InputSourceError(msg) from err
    return sorted(out[0]), sorted(out[1])


@dataclass(frozen=True)
class FolderSource:
    """A folder with one subfolder of images per camera (``cam_side``/``cam_front``, or the
    first two subfolders in name order); optional ``stamps.csv`` (file,stamp_s) in each."""

    path: Path
    fps: float = 30.0

    def camera_dirs(self) -> tuple[Path, Path]:
        """The side and front image folders."""
        if not self.path.is_dir():
            msg = f'{self.path}: frame folder not found'
            raise InputSourceError(msg)
        named = [self.path / c for c in topics.CAMERAS]
        if all(d.is_dir() for d in named):
            return named[0], named[1]
        subs = sorted(d for d in self.path.iterdir() if d.is_dir())
        if len(subs) < 2:
            msg = f'{self.path}: need two camera subfolders (cam_side, cam_front)'
            raise InputSourceError(msg)
        return subs[0], subs[1]

    def count(self) -> int:
        """Number of images."""
        return sum(len(_images(d)) for d in self.camera_dirs())

    def frames(self) -> Iterator[Frame]:
        """Yield the side folder's images, then the front folder's."""
        for cam, folder in enumerate(self.camera_dirs()):
            stamps = _folder_stamps(folder)
            for i, f in enumerate(_images(folder)):
                img = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
                if img is None:
                    LOG.warning('%s: unreadable image, skipped', f)
                    continue
                yield cam, stamps.get(f.name, i / self.fps), np.asarray(img, np.uint8)


def _images(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)


def _folder_stamps(folder: Path) -> dict[str, float]:
    path = folder / 'stamps.csv'
    if not path.is_file():
        return {}
    with path.open() as f:
        return {row['file']: float(row['stamp_s']) for row in csv.DictReader(f)}


Source = BagSource | VideoSource | FolderSource


def open_source(inputs: list[str], fps: float = 30.0, timestamps: str | None = None) -> Source:
    """Choose the source from the inputs: one bag, one folder, or two video files.

    Raises:
        InputSourceError: nothing recognisable at the given paths.
    """
    paths = [Path(p) for p in inputs]
    missing = [p for p in paths if not p.exists()]
    if missing:
        msg = f'{missing[0]}: input not found'
        raise InputSourceError(msg)
    if len(paths) == 2 and all(p.suffix.lower() in VIDEO_SUFFIXES for p in paths):
        stamps = read_timestamps_csv(Path(timestamps)) if timestamps else None
        return VideoSource((paths[0], paths[1]), stamps)
    if len(paths) == 1:
        p = paths[0]
        if p.suffix in ('.mcap', '.db3') or (p / 'metadata.yaml').is_file():
            return BagSource(p)
        if p.is_dir():
            return FolderSource(p, fps)
    msg = f'{" ".join(inputs)}: give one bag, one frame folder, or two video files'
    raise InputSourceError(msg)
