"""The two-camera pipeline's publication delay (``StereoTrackConfig.number_delay_frames``).

A marker that comes back as a new track is often numbered a few frames later (when the other
camera's pair check or the pair numbering names it). Offline, ``StereoMarkerTracker`` holds
each frame that many frames of its camera and gives it out with the numbers its new tracks got
meanwhile; live, the detector node publishes at once (delay 0).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.linker import Track
from dempath_recon.tracking.records import PixelFrame


class HeldFrame(NamedTuple):
    """A frame waiting to be given out.

    Attributes:
        camera: Its camera.
        arrival: Its count among that camera's frames.
        frame: The frame as numbered on arrival.
        track_ids: (k,) the track of each point.
        free: (k,) whether the point and its track were unnumbered on arrival.
    """

    camera: str
    arrival: int
    frame: PixelFrame
    track_ids: NDArray[np.int64]
    free: NDArray[np.bool_]


class ReleaseQueue:
    """Frames held ``delay`` frames of their camera, in arrival order."""

    def __init__(self, cameras: Iterable[str], delay: int) -> None:
        self.delay = delay
        self._held: deque[HeldFrame] = deque()
        self._arrived: dict[str, int] = dict.fromkeys(cameras, 0)

    def hold(self, frame: PixelFrame, track_ids: NDArray[np.int64],
             free: NDArray[np.bool_]) -> None:
        """Add a frame; frames older than the delay (nobody released them) are dropped."""
        self._arrived[frame.camera] += 1
        self._held.append(HeldFrame(frame.camera, self._arrived[frame.camera], frame,
                                    track_ids.copy(), free))
        self._held = deque(h for h in self._held if self._age(h) <= self.delay)

    def due(self) -> list[HeldFrame]:
        """The frames now ``delay`` frames old in their camera, in arrival order (removed from
        the queue; a camera's frames are not kept waiting behind the other camera's younger
        ones, which ``hold`` would then drop)."""
        out = [h for h in self._held if self._age(h) >= self.delay]
        if out:
            self._held = deque(h for h in self._held if self._age(h) < self.delay)
        return out

    def rest(self) -> list[HeldFrame]:
        """Every frame still held (removed from the queue)."""
        out = list(self._held)
        self._held.clear()
        return out

    def __len__(self) -> int:
        return len(self._held)

    def _age(self, held: HeldFrame) -> int:
        return self._arrived[held.camera] - held.arrival


def renumber(held: HeldFrame, tracks: Sequence[Track], fps: float) -> tuple[PixelFrame, int]:
    """The held frame with its unnumbered tracks' points numbered as their tracks are now, and
    how many points got a number.

    A point takes its track's number if the track kept its 2D links since that frame (no
    re-attachment, after which the number may be another marker's) and no other point of the
    frame has that number.
    """
    frame = held.frame
    if not held.free.any():
        return frame, 0
    by_id = {t.track_id: t for t in tracks}
    markers, gap, late = frame.markers.copy(), 1.5 / fps, 0
    for k in np.flatnonzero(held.free).tolist():
        track = by_id.get(int(held.track_ids[k]))
        if track is None or track.marker < 0 or track.marker in markers:
            continue
        stamps = [h[0] for h in track.history if h[0] >= frame.stamp_s]
        if not stamps or stamps[0] != frame.stamp_s or np.any(np.diff(stamps) > gap):
            continue  # re-attached (or lost) since: the number may be another marker's
        markers[k] = track.marker
        late += 1
    return frame._replace(markers=markers), late
