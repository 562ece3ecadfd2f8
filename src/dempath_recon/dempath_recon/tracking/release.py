"""The two-camera pipeline's publication delay (``StereoTrackConfig.number_delay_frames``).

A marker that comes back as a new track is often numbered a few frames later (when the other
camera's pair check or the pair numbering names it). Offline, ``StereoMarkerTracker`` holds
each frame that many frames of its camera and gives it out with the numbers its new tracks got
meanwhile; live, the detector node publishes at once (delay 0). A point withheld on arrival
because its track's re-attachment, jump or faint spot waited for the other camera goes out
with that number once a later pair check of the same track passes within the delay, the track
unbroken in between (``fill_confirmed``).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Mapping
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
        waiting: (k,) the number a point was withheld from on arrival because the other
            camera had not confirmed its track yet (-1: none).
    """

    camera: str
    arrival: int
    frame: PixelFrame
    track_ids: NDArray[np.int64]
    free: NDArray[np.bool_]
    waiting: NDArray[np.int32]


class ReleaseQueue:
    """Frames held ``delay`` frames of their camera, in arrival order."""

    def __init__(self, cameras: Iterable[str], delay: int) -> None:
        self.delay = delay
        self._held: deque[HeldFrame] = deque()
        self._arrived: dict[str, int] = dict.fromkeys(cameras, 0)

    def hold(self, frame: PixelFrame, track_ids: NDArray[np.int64],
             free: NDArray[np.bool_], waiting: NDArray[np.int32] | None = None) -> None:
        """Add a frame (``waiting``: see :class:`HeldFrame`; None: no point waits); frames
        older than the delay (nobody released them) are dropped."""
        self._arrived[frame.camera] += 1
        if waiting is None:
            waiting = np.full(len(track_ids), -1, np.int32)
        self._held.append(HeldFrame(frame.camera, self._arrived[frame.camera], frame,
                                    track_ids.copy(), free, waiting))
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

    def keep_free(self, camera: str, track_id: int, before_s: float) -> None:
        """Leave the points of ``track_id`` in ``camera``'s frames held from before
        ``before_s`` [s] unnumbered, whatever number the track takes now (its number was
        given back on evidence from ``before_s`` on: before then the track may have been on
        another marker's spot)."""
        for held in self._held:
            if held.camera == camera and held.frame.stamp_s < before_s:
                held.free[held.track_ids == track_id] = False
                held.waiting[held.track_ids == track_id] = -1

    def __len__(self) -> int:
        return len(self._held)

    def _age(self, held: HeldFrame) -> int:
        return self._arrived[held.camera] - held.arrival


def unbroken(track: Track, stamp_s: float, fps: float) -> bool:
    """Whether ``track`` was linked at ``stamp_s`` and kept its 2D links since (no gap of more
    than 1.5 frame periods: no loss and re-attachment, after which it may be another marker)."""
    stamps = [h[0] for h in track.history if h[0] >= stamp_s]
    return bool(stamps) and stamps[0] == stamp_s and not np.any(np.diff(stamps) > 1.5 / fps)


def fill_confirmed(held: HeldFrame, frame: PixelFrame, tracks: Mapping[int, Track],
                   confirmed: dict[int, float], fps: float) -> tuple[PixelFrame, int]:
    """``frame`` (the held one, maybe renumbered) with its points that waited for the other
    camera given their number, and how many.

    A point withheld on arrival because its track waited for the other camera's confirmation
    (a re-attachment off its prediction, a jump, a faint spot) takes the number it waited for
    when a pair check of the same track passed after that frame (``confirmed``: track id ->
    stamp of its last passed check [s]), the track still holds that number, kept its 2D links
    from that frame to now (so the confirmed spot and the withheld one are the same marker's),
    and no other point of the frame has the number.
    """
    if not (held.waiting >= 0).any():
        return frame, 0
    markers, filled = frame.markers.copy(), 0
    for k in np.flatnonzero(held.waiting >= 0).tolist():
        m, tid = int(held.waiting[k]), int(held.track_ids[k])
        track = tracks.get(tid)
        if track is None or track.marker != m or m in markers or markers[k] >= 0 \
                or confirmed.get(tid, -np.inf) <= frame.stamp_s \
                or not unbroken(track, frame.stamp_s, fps):
            continue
        markers[k] = m
        filled += 1
    return frame._replace(markers=markers), filled


def renumber(held: HeldFrame, tracks: Mapping[int, Track], fps: float
             ) -> tuple[PixelFrame, int]:
    """The held frame with its unnumbered tracks' points numbered as their tracks are now, and
    how many points got a number.

    A point takes its track's number if the track kept its 2D links since that frame (no
    re-attachment, after which the number may be another marker's) and no other point of the
    frame has that number.
    """
    frame = held.frame
    if not held.free.any():
        return frame, 0
    markers, late = frame.markers.copy(), 0
    for k in np.flatnonzero(held.free).tolist():
        track = tracks.get(int(held.track_ids[k]))
        if track is None or track.marker < 0 or track.marker in markers:
            continue
        if not unbroken(track, frame.stamp_s, fps):
            continue  # re-attached (or lost) since: the number may be another marker's
        markers[k] = track.marker
        late += 1
    return frame._replace(markers=markers), late
