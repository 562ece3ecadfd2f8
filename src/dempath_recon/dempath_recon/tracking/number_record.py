"""Which rule numbered what: a record of every number a track was given or had taken back.

The two-camera tracker (:class:`~dempath_recon.tracking.stereo.StereoMarkerTracker`) runs its
numbering rules in a fixed order on every frame (the grid fit, numbering by the epipolar line,
pair numbering, track pairs, elimination, the pair checks, ...), each able to give a track a
number or take one back. A wrong number given out says nothing about which rule gave it; this
record does. Each change of a track's number is kept with the rule that made it, the frame
(camera, stamp), the track's spot then, and the evidence: the events the rule wrote in that
frame about that track or marker. Each frame's track of each point, and its numbers on arrival,
are kept too, so that a point given out (perhaps later, with a number its track got
meanwhile) can be traced to the change behind its number (:meth:`NumberRecord.behind`).

It is off by default (``StereoTrackConfig.record_numbers``): a live node would keep it growing.
When on, it costs one attribute write per rule and frame, and a little work per change of a
number (a few per look). The linker calls :meth:`NumberRecord.noted` through
``MarkerTracker.on_number``, so every numbering path is recorded without each rule knowing.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.linker import Track

FrameKey = tuple[str, int]  # (camera, stamp us)
REATTACHED = 'reattached'  # the rule name of a numbered track's re-attachment (the linker)
EVIDENCE = 3  # events kept as a change's evidence when none names its track or number


class NumberChange(NamedTuple):
    """One change of a track's number (or a numbered track's re-attachment).

    Attributes:
        camera: the track's camera.
        stamp_s: the frame it happened in [s].
        track_id: the track.
        rule: the rule that made it (the step of ``StereoMarkerTracker.update_detections``;
            ``reattached``: the linker re-attached the numbered track after a gap).
        before: the track's number before (-1: none).
        after: its number after (-1: taken back).
        uv: (2,) the track's last spot then [px].
        seen_s: when the track was last at ``uv`` [s] (a rule run on one camera's frame may
            number the other camera's tracks, last seen in that camera's frame).
        evidence: the rule's events of that frame naming the track or either number (none
            does: all the rule's events of that frame, such as the grid fit's summary).
    """

    camera: str
    stamp_s: float
    track_id: int
    rule: str
    before: int
    after: int
    uv: tuple[float, float]
    seen_s: float
    evidence: tuple[str, ...]


def _key(camera: str, stamp_s: float) -> FrameKey:
    return camera, round(stamp_s * 1e6)


def _names(ev: str, change: NumberChange) -> bool:
    """Whether an event names the change's track (of its camera) or one of its numbers."""
    if not ev.startswith(f'{change.camera}:'):
        return False
    words = (f'track {change.track_id} ', f'track {change.track_id}:',
             *(f'marker {m}' for m in (change.before, change.after) if m >= 0))
    return any(w in ev for w in words)


class NumberRecord:
    """Every change of a track's number, with its rule, frame and evidence, and each frame's
    tracks.

    Call :meth:`begin` before each rule of a frame (with the frame's event list),
    :meth:`noted` from the linker's ``on_number`` (:meth:`hook`), and :meth:`frame_done`
    after the frame's last rule.
    """

    def __init__(self) -> None:
        self.changes: list[NumberChange] = []
        # per frame: (k,) the track of each point and (k,) its number on arrival
        self.frames: dict[FrameKey, tuple[NDArray[np.int64], NDArray[np.int32]]] = {}
        self._rule, self._camera, self._stamp_s = 'link', '', 0.0
        self._events: list[str] = []
        self._open = 0  # first change whose evidence is not filled yet
        self._seen = 0  # events of the frame before the current rule began

    def hook(self, camera: str) -> Callable[[Track, int], None]:
        """The linker's ``on_number`` callback for ``camera``."""
        def on_number(track: Track, marker: int) -> None:
            self.noted(camera, track, marker)
        return on_number

    def begin(self, rule: str, camera: str, stamp_s: float, events: list[str]) -> None:
        """The next rule of a frame starts (``events``: the frame's event list, shared)."""
        self._close()
        self._rule, self._camera, self._stamp_s = rule, camera, stamp_s
        self._events, self._seen = events, len(events)

    def noted(self, camera: str, track: Track, marker: int) -> None:
        """A track of ``camera`` takes ``marker`` (-1: its number is taken back)."""
        self.changes.append(NumberChange(camera, self._stamp_s, track.track_id, self._rule,
                                         track.marker, marker,
                                         (float(track.uv[0]), float(track.uv[1])),
                                         track.last_stamp_s, ()))

    def reattached(self, camera: str, stamp_s: float, tracks: list[Track]) -> None:
        """Note the numbered tracks the linker re-attached in this frame (a track carries its
        number onto the spot it re-attached to: a switch may start there)."""
        for t in tracks:
            if t.marker >= 0 and t.reattached is not None and t.reattached[0] == stamp_s:
                self.changes.append(NumberChange(
                    camera, stamp_s, t.track_id, REATTACHED, t.marker, t.marker,
                    (float(t.uv[0]), float(t.uv[1])), stamp_s,
                    (f'{t.reattached[1]:.1f} px from its prediction',)))

    def frame_done(self, camera: str, stamp_s: float, track_ids: NDArray[np.int64],
                   markers: NDArray[np.int32]) -> None:
        """The frame's last rule ran: keep each point's track and number on arrival."""
        self._close()
        self._rule, self._camera = 'link', ''
        self.frames[_key(camera, stamp_s)] = (np.array(track_ids, np.int64),
                                              np.array(markers, np.int32))

    def _close(self) -> None:
        """Fill the evidence of the current rule's changes from the events it wrote."""
        new = self._events[self._seen:]
        for i in range(self._open, len(self.changes)):
            change = self.changes[i]
            if change.rule != REATTACHED and not change.evidence:
                named = tuple(ev for ev in new if _names(ev, change))
                self.changes[i] = change._replace(evidence=named or tuple(new[:EVIDENCE]))
        self._open = len(self.changes)

    def track_of(self, camera: str, stamp_s: float, index: int) -> int | None:
        """The track of point ``index`` of a frame (None: the frame is not recorded)."""
        got = self.frames.get(_key(camera, stamp_s))
        return None if got is None or index >= len(got[0]) else int(got[0][index])

    def arrival_number(self, camera: str, stamp_s: float, index: int) -> int | None:
        """The number point ``index`` of a frame had on arrival (None: not recorded)."""
        got = self.frames.get(_key(camera, stamp_s))
        return None if got is None or index >= len(got[1]) else int(got[1][index])

    def behind(self, camera: str, stamp_s: float, index: int, number: int,
               ) -> NumberChange | None:
        """The change that gave point ``index`` of a frame its number ``number``: the last
        change of its track to that number at or before the frame, else the first after it
        (a number given later and filled in at release); None when there is none."""
        track = self.track_of(camera, stamp_s, index)
        if track is None:
            return None
        mine = [c for c in self.changes if c.camera == camera and c.track_id == track
                and c.after == number and c.rule != REATTACHED]
        before = [c for c in mine if c.stamp_s <= stamp_s + 1e-9]
        if before:
            return before[-1]
        return mine[0] if mine else None

    def history(self, camera: str, track_id: int) -> list[NumberChange]:
        """Every change of one track, in order (re-attachments included)."""
        return [c for c in self.changes if c.camera == camera and c.track_id == track_id]
