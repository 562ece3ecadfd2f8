"""A click file as a stream of per-camera pixel frames, in frame order, for publishing.

Manual and automatic tracks flow through the same graph: the clicker node publishes each frame's
clicks of each camera as one ``dempath_msgs/PixelPoints`` message (``SOURCE_CLICKED``) stamped
with that camera's image stamp, exactly where a detector publishes its points, so the
reconstructor pairs them by stamp within its slop as it pairs detections.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath import topics
from dempath_recon.clicker.click_csv import Click, ClickBounds, parse_markers, read_clicks_text
from dempath_recon.clicker.frames import FrameSet, open_frames
from dempath_recon.errors import ClickError


@dataclass(frozen=True)
class ClickFrame:
    """The clicks of one camera in one frame.

    Attributes:
        frame: Frame index of the session.
        camera: Camera name.
        stamp_s: The camera image's stamp [s].
        ids: (m,) marker numbers, ascending.
        uv: (m, 2) centres [px].
    """

    frame: int
    camera: str
    stamp_s: float
    ids: NDArray[np.int64]
    uv: NDArray[np.float64]


def frame_stamps(frames: FrameSet) -> dict[tuple[int, str], float]:
    """The stamp [s] of every (frame index, camera) that has an image."""
    return {(k, camera): image.stamp_s for k, images in enumerate(frames.frames)
            for camera, image in images.items() if image is not None}


def click_frames(clicks: Sequence[Click], stamps: Mapping[tuple[int, str], float],
                 fps: float = 50.0) -> list[ClickFrame]:
    """Group clicks by (frame, camera) in frame order; a missing stamp is ``frame / fps``."""
    groups: dict[tuple[int, str], list[Click]] = {}
    for click in sorted(clicks, key=lambda c: c.key):
        groups.setdefault((click.frame, click.camera), []).append(click)
    return [ClickFrame(frame, camera, stamps.get((frame, camera), frame / fps),
                       np.array([c.marker for c in group], np.int64),
                       np.array([[c.x, c.y] for c in group], np.float64).reshape(-1, 2))
            for (frame, camera), group in groups.items()]


@dataclass(frozen=True)
class ClickerConfig:
    """Settings of the clicker node.

    Attributes:
        clicks_file: The click CSV (``frame,camera,marker,x,y``) or a per-particle CSV [path].
        frames: The bag or folder the clicks were made on, for the image stamps; '' for none.
        fps: Frame rate when a stamp is not known (folders, no ``frames``) [1/s].
        markers: Marker numbers the file may hold (e.g. ``1-15``).
        image_width: Image width when ``frames`` is '' [px].
        image_height: Image height when ``frames`` is '' [px].
        rate_hz: Frames published per second of wall time.
        wait_for_subscribers: Subscribers each topic must have before the first frame.
        wait_timeout_s: Longest wait for them [s].
    """

    clicks_file: str
    frames: str = ''
    fps: float = 50.0
    markers: str = '1-15'
    image_width: int = 1920
    image_height: int = 1080
    rate_hz: float = 50.0
    wait_for_subscribers: int = 0
    wait_timeout_s: float = 10.0

    def __post_init__(self) -> None:
        checks = {'clicks_file': bool(self.clicks_file), 'fps': self.fps > 0,
                  'image_width': self.image_width > 0, 'image_height': self.image_height > 0,
                  'rate_hz': self.rate_hz > 0,
                  'wait_for_subscribers': self.wait_for_subscribers >= 0,
                  'wait_timeout_s': self.wait_timeout_s >= 0}
        for name, ok in checks.items():
            if not ok:
                msg = f'{name}: out of range, got {getattr(self, name)!r}'
                raise ValueError(msg)

    @classmethod
    def from_params(cls, values: Mapping[str, object]) -> ClickerConfig:
        """Build from the node's parameter values (names as the fields)."""
        return cls(**values)  # type: ignore[arg-type]


def load_click_frames(config: ClickerConfig) -> list[ClickFrame]:
    """Read, check and group the clicks of ``config.clicks_file``.

    Raises:
        ClickError: The file or the frame source is unreadable, or a click is invalid.
    """
    stamps: dict[tuple[int, str], float] = {}
    if config.frames:
        frames = open_frames(config.frames, config.fps)
        bounds = ClickBounds(len(frames.frames), frames.sizes, parse_markers(config.markers))
        stamps = frame_stamps(frames)
    else:
        size = (config.image_width, config.image_height)
        bounds = ClickBounds(2**31 - 1, dict.fromkeys(topics.CAMERAS, size),
                             parse_markers(config.markers))
    path = Path(config.clicks_file)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as err:
        msg = f'{path}: cannot read the click file ({err})'
        raise ClickError(msg) from err
    return click_frames(read_clicks_text(text, bounds, str(path)), stamps, config.fps)
