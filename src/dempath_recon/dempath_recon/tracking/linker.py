"""Tracking detected markers across the frames of one camera: prediction and one-to-one links.

Each track predicts its marker's next position with a constant velocity (in pixels per second,
so dropped frames and uneven stamps only lengthen the step). Detections are linked to tracks by
a one-to-one assignment (``scipy.optimize.linear_sum_assignment``, the Hungarian/Jonker-Volgenant
solution), with gates: a link longer than ``gate_px`` (a lost track: ``reattach_px``) is never
made. Each link scores the longest link allowed (the larger gate) minus its length, and the
assignment maximises the total: every link inside its gate is worth making on its own,
but a track is not moved off the spot it predicts to a farther one just so that one more link
(a lost track's re-attachment) can be made, unless the extra link is worth more than the
distance the moves add. (Minimising the total distance among the assignments with the most
links, the previous rule, let a lost track re-attach to a spot a running track predicted within
1 px by pushing that track 14 px onto a marker reappearing beside it: both tracks then followed
the wrong marker, on the bundled render.) That worth still pays for a chain of moves: on a
heaving cohesive bed several markers move together, and when one of them is covered its track
(still running, its 25 px gate) can take the next marker's spot 11 px off, that marker's track
the next one's 9 px off, and so on, as long as the moves add less than the one extra link is
worth (a render of hidden seed 61, light x0.65: the front camera's tracks of markers 10, 9
and 8 each moved one marker over at once; 9 wrong numbers and 4 wrong 3D points followed).
So a running track and a detection that are each other's nearest, within ``hold_px`` (2 px,
a quarter of a marker's image), are linked first (:func:`held_links`): a spot its track
predicts that well is that marker's, and no chain may move it; the assignment links the rest.
Unless another track (running or lost) predicts the same spot within a marker's image diameter
(``hold_rival_px``): two markers can be there, and a prediction within 2 px is no proof. Two
fast markers crossing (a tool driven at 1 m/s, 4-5 px a frame): the side camera's track of
marker 3 predicted marker 8's spot 1.6 px off, the track of 8, lost a frame before, 5.7 px off
(its own spot 6.0 px from 3's prediction, 12.4 px from 8's); held, 3 took 8's spot and 8
re-attached onto 3's: the two numbers swapped for the rest of the pass (5 switches, 5 wrong 3D
points).
A fast track's hold knows its speed (:func:`hold_radii`, :func:`rival_tracks`). A constant
velocity misses an accelerating marker by a share of its step, not by a fixed number of
pixels: a track moving ``s`` px a frame holds a spot within ``hold_step_share * s`` of its
prediction when that exceeds ``hold_px``. And such a fast track's hold is not given up for a
track unseen for longer than ``hold_rival_unseen_s``: around a marker that fast the sand moves
as fast, and a marker covered that long moved with it, so its old track lying near the spot
says nothing. With the tool at twice its speed (a tuning render of hidden seed 111, the side
camera) the running track of marker 7, moving 12 px a frame, predicted its own spot 2.1 px off
and a spot of marker 3, coming out of the sand, 8.9 px off; 3's track, unseen for 0.06 s,
predicted 7's spot 7.7 px off, so nothing was held and the assignment's two ways of making both
links were worth the same (63.4): 3's track re-attached onto 7 and 7's track took 3 (6
switches, 1 wrong 3D point). Held by its step and without that rival, 7 keeps its spot. Slow
tracks keep every rival: a marker that sank where it lay comes out where its old track
predicts it (a cohesive dusk render of hidden seed 129: marker 3 back 2.8 px from its track,
unseen 0.2 s, beside marker 4's track 1.4 px off; ignoring that rival for slow tracks too
moved 4's number onto 3: 15 -> 26 switches on that look).
The assignment weighs every track's miss alike, but a lost track's prediction is much the worse:
its marker moved on with the sand, unseen. Two markers side by side, one lost, then give their
spots to the cheaper sum of link lengths, which can be the swap: on heldout21's carriage look
(released for tuning) marker 3 was covered in both cameras for 0.1 s while marker 2 ran past
it; when 3 came out 8-9 px beside 2, each camera's running track of 2 moved onto 3's spot (5-6
px off its prediction) so that 3's lost track could re-attach onto 2's (4-7 px from where it
was last seen), against 1.7-2.5 and 10-13 px the right way. Both cameras swapped alike, every
later pair check passed, and 24 points went out under the other marker's number. So once the
assignment has chosen which links to make (which tracks link, which spots are taken: a
re-attachment against a new track is decided as before), who takes which of those spots is
decided again by each track's miss in units of its expected miss (:meth:`MarkerTracker._reassign`):
``hold_px`` for a running track, growing for a lost one as ``lost_spread_px`` after
``SPREAD_S`` unseen, to the power ``SPREAD_POWER`` of the time (the position error of a
constant-velocity prediction under random acceleration); 2 px against 15 px there, so 1.7/2 +
9.9/15 = 1.5 expected misses the right way against 5.0/2 + 4.1/15 = 2.8 the swap (the side
camera). The spots change hands only when that lowers the sum by at least one running track's
expected miss (``REASSIGN_MARGIN``): a track lost a frame or two ago predicts nearly as well as
a running one (without the margin, near ties broken that way swapped markers a frame after a
merge on two dusk looks: ``t107_dusk`` 0 -> 5 switches, heldout21's ``M139_dusk`` 7 -> 9).
Why not trackpy's linking: with 15 markers the exact global assignment costs microseconds,
needs no new dependency, and every decision (link, loss, re-attachment) is explicit and
reported, which the paper's validation needs; trackpy's
subnetwork search is built for thousands of dense particles.

The caller may bar links (``update``'s ``barred``: track id -> (n,) detections that track may
not take): the two-camera tracker bars a numbered track from detections its marker cannot be,
by the other camera's sighting of the marker (off its epipolar line), so the epipolar constraint
decides the link itself rather than a check after it (:mod:`~dempath_recon.tracking.link_guide`).

With the tool's speed known (``max_image_speed_px_s``, set by
:mod:`~dempath_recon.tracking.speed_bound`), no link moves a track farther from its last
position than its marker can have moved since: a covered marker's track then cannot take a
neighbour's spot a pitch away within a frame or two.

A track whose marker is not found (covered by sand, out of view) becomes LOST at once: it
keeps its last position and is never linked to a detection farther than ``reattach_px`` from
where it was last seen (plus its predicted drift). A detection near a lost track's last position
re-attaches it, and the frame reports the re-attachment with the gap. A detection that matches
no track starts a new track without a marker number (-1) unless the caller numbers it. Tracks
are never merged: two markers can never share a track.

Streaming: :meth:`MarkerTracker.update` takes one frame; :func:`track_sequence` is the batch
form over a sequence of frames and gives the same result (tested).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from dempath_recon.tracking.detect import Detections

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
UNNUMBERED = -1  # marker number of a track that is not (yet) identified
SPREAD_S = 0.1  # ``lost_spread_px`` is a lost marker's expected miss after this long unseen [s]
SPREAD_POWER = 1.5  # ... and it grows as (unseen / SPREAD_S) ** SPREAD_POWER: a constant-velocity
# prediction under random (white-noise) acceleration has a position variance growing as t**3
# (q t**3 / 3: the continuous white-noise acceleration model, Bar-Shalom, Li, Kirubarajan 2001,
# "Estimation with Applications to Tracking and Navigation", chapter 6)
BARRED = 1e9  # the weighted miss of a link outside its gate (or barred): never chosen
REASSIGN_MARGIN = 1.0  # the spots are given again only when that lowers the summed misses, in
# expected misses, by at least this many running tracks' expected misses (``hold_px``)
SLACK_PX = 3.0  # a link may exceed the image speed bound by this much [px] (centroid noise,
# a covered marker's visible part moving over it; ``speed_bound`` explains the bound)


@dataclass(frozen=True)
class TrackerConfig:
    """Settings of the frame-to-frame linker.

    Attributes:
        gate_px: longest link from a prediction to a detection [px].
        reattach_px: longest jump from a lost track's last position to a reappearing marker [px].
        max_lost_s: a lost track is dropped after this long unseen [s].
        velocity_decay: share of the velocity kept per second while lost [-] (covered markers
            stop with the sand around them).
        faint_gate_px: longest link of a numbered track left without a spot to a faint one
            (``Detections.faint``: below the detector's threshold) [px]; 0: faint spots unused.
        exposure_s: the cameras' exposure [s]: a track's faint search looks for a streak
            along its velocity times this (:mod:`~dempath_recon.tracking.streak`); 0: spots
            only.
        hold_px: a running track and a detection that are each other's nearest, this near
            its prediction, are linked before the assignment (:func:`held_links`) [px]; 0:
            the assignment decides every link.
        hold_rival_px: a detection another track (running or lost) predicts within this is
            held for none (:func:`held_links`) [px]; None: 0 here, the markers' image diameter
            when the two-camera tracker sets it per camera
            (:func:`~dempath_recon.tracking.speed_bound.camera_tracker`); 0: held regardless.
        max_image_speed_px_s: the fastest a marker moves in this camera's image [px/s]: a
            detection farther from a track's last position than this over the time since
            (plus ``SLACK_PX``) is never linked to it
            (:mod:`~dempath_recon.tracking.speed_bound`); 0: no bound.
        hold_step_share: a running track's hold radius grows to this share of its predicted
            step (its velocity times the time since it was seen) where that exceeds
            ``hold_px`` (:func:`hold_radii`) [-]; 0: ``hold_px`` whatever the speed.
        lost_spread_px: a lost marker's expected miss after ``SPREAD_S`` unseen [px], growing
            as the time unseen to the power ``SPREAD_POWER``: who takes which of the spots the
            assignment links is decided again by each track's miss in units of its expected
            miss (:meth:`MarkerTracker._reassign`); 0: by the summed misses alone.
        hold_rival_unseen_s: a track unseen for longer than this is no rival of a fast
            track's held link (one whose radius its step widened: :func:`rival_tracks`) [s];
            0: every other track is (as before session 20).
    """

    gate_px: float = 25.0
    reattach_px: float = 40.0
    max_lost_s: float = 2.0
    velocity_decay: float = 0.05
    faint_gate_px: float = 4.0
    exposure_s: float = 0.0
    hold_px: float = 2.0
    hold_rival_px: float | None = None
    max_image_speed_px_s: float = 0.0
    hold_step_share: float = 0.25  # markers pushed by a tool at 2x speed: a 12 px step missed
    # by 2.1 px (a tenth to a fifth of the step on the fast tuning looks' right links)
    lost_spread_px: float = 15.0  # heldout21's carriage look (released for tuning): marker 3
    # came out 15 px from where it sank 0.1 s before, carried by the bed beside marker 2
    hold_rival_unseen_s: float = 0.05  # between two and three frame periods at 50 FPS: a track
    # lost a frame before (unseen 0.04 s) still rivals (two markers crossing), one lost for two
    # frames (0.06 s) no more

    def __post_init__(self) -> None:
        for name in ('gate_px', 'reattach_px', 'max_lost_s'):
            if not getattr(self, name) > 0:
                msg = f'{name}: must be > 0, got {getattr(self, name)!r}'
                raise ValueError(msg)
        if not 0 <= self.hold_px < self.gate_px:
            msg = f'hold_px: must be in [0, gate_px), got {self.hold_px!r}'
            raise ValueError(msg)
        if not 0 <= self.exposure_s < 1:
            msg = f'exposure_s: must be in [0, 1) s, got {self.exposure_s!r}'
            raise ValueError(msg)
        if self.hold_rival_px is not None and not self.hold_rival_px >= 0:
            msg = f'hold_rival_px: must be >= 0 or None, got {self.hold_rival_px!r}'
            raise ValueError(msg)
        if not self.max_image_speed_px_s >= 0:
            msg = f'max_image_speed_px_s: must be >= 0, got {self.max_image_speed_px_s!r}'
            raise ValueError(msg)
        if not 0 <= self.hold_step_share < 1:
            msg = f'hold_step_share: must be in [0, 1), got {self.hold_step_share!r}'
            raise ValueError(msg)
        if not self.lost_spread_px >= 0:
            msg = f'lost_spread_px: must be >= 0, got {self.lost_spread_px!r}'
            raise ValueError(msg)
        if not self.hold_rival_unseen_s >= 0:
            msg = f'hold_rival_unseen_s: must be >= 0, got {self.hold_rival_unseen_s!r}'
            raise ValueError(msg)


@dataclass
class Track:
    """One marker's track in one camera (mutable state of the streaming linker)."""

    track_id: int
    marker: int
    uv: FloatArray  # (2,) last seen [px]
    velocity: FloatArray  # (2,) [px/s]
    last_stamp_s: float
    lost: bool = False
    history: list[tuple[float, float, float]] = field(default_factory=list)  # (t, u, v)
    link_px: float = 0.0  # largest distance of a linked detection from the prediction since
    # the caller last reset it (a check against the other camera passed) [px]
    reattach_px: float = 0.0  # the same, of re-attachments only (a lost track taking a spot)
    reattached: tuple[float, float] | None = None  # (stamp s, miss px) of its last re-attachment
    back_unchecked: bool = False  # re-attached, and no check against the other camera has
    # passed since (the caller resets it)
    faint_stamp: float | None = None  # stamp of its last link to a faint spot [s]

    def predict(self, stamp_s: float, decay: float) -> FloatArray:
        """(2,) expected position at ``stamp_s`` [px]."""
        dt = stamp_s - self.last_stamp_s
        vel = self.velocity * (decay ** dt if self.lost else 1.0)
        return np.asarray(self.uv + vel * dt, np.float64)


class TrackFrame(NamedTuple):
    """What the tracker reports for one frame.

    Attributes:
        stamp_s: frame time [s].
        track_ids: (k,) tracks seen in this frame.
        markers: (k,) their marker numbers (-1 = not identified).
        uv: (k, 2) positions [px].
        confidence: (k,) detector confidence.
        events: human-readable events (``lost``, ``re-attached``, ``new``, ``dropped``).
    """

    stamp_s: float
    track_ids: NDArray[np.int64]
    markers: NDArray[np.int32]
    uv: FloatArray
    confidence: FloatArray
    events: tuple[str, ...]


@dataclass
class TrackCounts:
    """Running totals of one camera's tracker."""

    frames: int = 0
    detected: int = 0
    tracked: int = 0
    lost: int = 0
    reattached: int = 0
    new_tracks: int = 0
    faint: int = 0  # links to faint spots
    out_of_order: int = 0


class MarkerTracker:
    """Streaming linker of one camera's detections.

    Args:
        config: linker settings.
    """

    def __init__(self, config: TrackerConfig | None = None) -> None:
        self.config = config or TrackerConfig()
        self.tracks: list[Track] = []
        self.counts = TrackCounts()
        self._next_id = 0
        self._last_stamp: float | None = None
        # called with (track, new number) before a track's number changes (a record of who
        # numbered what, ``number_record``); None: nobody listens
        self.on_number: Callable[[Track, int], None] | None = None

    def seed(self, uv: FloatArray, markers: NDArray[np.int32], stamp_s: float) -> None:
        """Start numbered tracks at positions (m, 2) px (the initial grid), before frame one."""
        for p, m in zip(np.asarray(uv, np.float64), markers, strict=True):
            self._new(p, int(m), stamp_s)
        self._last_stamp = stamp_s

    def _new(self, uv: FloatArray, marker: int, stamp_s: float) -> Track:
        track = Track(self._next_id, marker, np.array(uv, np.float64), np.zeros(2), stamp_s)
        track.history.append((stamp_s, float(uv[0]), float(uv[1])))
        self._next_id += 1
        self.tracks.append(track)
        return track

    def update(self, stamp_s: float, det: Detections,
               barred: dict[int, NDArray[np.bool_]] | None = None) -> TrackFrame:
        """Link one frame's detections; frames older than the last one are refused (counted).

        ``barred``: track id -> (n,) bool, the detections that track may not be linked to
        (its marker cannot be there); tracks not in it may take any detection in their gate.
        """
        if self._last_stamp is not None and stamp_s <= self._last_stamp:
            self.counts.out_of_order += 1
            msg = f'frame at {stamp_s:.6f} s not after {self._last_stamp:.6f} s: skipped'
            LOG.warning(msg)
            return TrackFrame(stamp_s, np.zeros(0, np.int64), np.zeros(0, np.int32),
                              np.zeros((0, 2)), np.zeros(0), (msg,))
        self._last_stamp = stamp_s
        self.counts.frames += 1
        self.counts.detected += len(det.uv)
        events: list[str] = []
        self._expire(stamp_s, events)
        links = self._assign(stamp_s, det.uv, barred or {})
        linked_tracks: set[int] = set()
        ids, markers, uvs, conf = [], [], [], []
        for ti, di in links:
            track = self.tracks[ti]
            self._advance(track, det.uv[di], stamp_s, events)
            linked_tracks.add(ti)
            ids.append(track.track_id)
            markers.append(track.marker)
            uvs.append(det.uv[di])
            conf.append(det.confidence[di])
        for ti, spot in self._assign_faint(stamp_s, det, linked_tracks):
            track = self.tracks[ti]
            self._advance(track, spot, stamp_s, events)
            track.faint_stamp = stamp_s
            linked_tracks.add(ti)
            self.counts.faint += 1
            ids.append(track.track_id)
            markers.append(track.marker)
            uvs.append(spot)
            conf.append(0.0)
        for ti, track in enumerate(self.tracks):
            if ti not in linked_tracks and not track.lost:
                track.lost = True
                self.counts.lost += 1
                events.append(f'lost track {track.track_id} (marker {track.marker}) at '
                              f'({track.uv[0]:.1f}, {track.uv[1]:.1f}) px')
        used = {di for _, di in links}
        for di in range(len(det.uv)):
            if di not in used:
                track = self._new(det.uv[di], UNNUMBERED, stamp_s)
                self.counts.new_tracks += 1
                events.append(f'new track {track.track_id} at ({det.uv[di][0]:.1f}, '
                              f'{det.uv[di][1]:.1f}) px')
                ids.append(track.track_id)
                markers.append(UNNUMBERED)
                uvs.append(det.uv[di])
                conf.append(det.confidence[di])
        self.counts.tracked += len(links)
        return TrackFrame(stamp_s, np.asarray(ids, np.int64), np.asarray(markers, np.int32),
                          np.asarray(uvs, np.float64).reshape(-1, 2),
                          np.asarray(conf, np.float64), tuple(events))

    def _expire(self, stamp_s: float, events: list[str]) -> None:
        keep = []
        for track in self.tracks:
            if track.lost and stamp_s - track.last_stamp_s > self.config.max_lost_s:
                events.append(f'dropped track {track.track_id} (marker {track.marker}): '
                              f'unseen for {stamp_s - track.last_stamp_s:.2f} s')
            else:
                keep.append(track)
        self.tracks = keep

    def _assign(self, stamp_s: float, uv: FloatArray, barred: dict[int, NDArray[np.bool_]],
                ) -> list[tuple[int, int]]:
        """One-to-one links (track index, detection index) inside the gates, none barred."""
        if not self.tracks or len(uv) == 0:
            return []
        pred = np.array([t.predict(stamp_s, self.config.velocity_decay) for t in self.tracks])
        cost = np.linalg.norm(pred[:, None, :] - uv[None, :, :], axis=2)
        gate = np.array([self.config.reattach_px if t.lost else self.config.gate_px
                         for t in self.tracks])
        for row, track in enumerate(self.tracks):
            bar = barred.get(track.track_id)
            if bar is not None:
                cost[row, bar] = np.inf  # outside every gate: never linked
        if self.config.max_image_speed_px_s > 0:  # farther than the marker can have gone
            cost[self._out_of_reach(stamp_s, uv)] = np.inf
        # a link's worth: the longest link allowed minus its length; no link (or one outside its
        # gate, or one exactly as long as the larger gate) is worth 0, so one more link is made
        # only when it is worth more than the misses the rearrangement it needs adds
        reach = max(self.config.gate_px, self.config.reattach_px)
        worth = np.where(cost <= gate[:, None], reach - cost, 0.0)
        radii = hold_radii(self.tracks, stamp_s, self.config)
        held = held_links(cost, np.array([not t.lost for t in self.tracks]),
                          radii, self.config.hold_rival_px or 0.0,
                          rival_tracks(self.tracks, stamp_s, self.config.hold_rival_unseen_s,
                                       radii > self.config.hold_px))
        if held:
            worth[[r for r, _ in held], :] = 0.0
            worth[:, [c for _, c in held]] = 0.0
        rows, cols = linear_sum_assignment(worth, maximize=True)
        made = [(int(r), int(c)) for r, c in zip(rows, cols, strict=True)
                if cost[r, c] <= gate[r] and worth[r, c] > 0]
        return sorted(held + self._reassign(stamp_s, made, cost, gate))

    def _reassign(self, stamp_s: float, made: list[tuple[int, int]], cost: FloatArray,
                  gate: FloatArray) -> list[tuple[int, int]]:
        """The assignment's links ``made`` (track index, detection index) with their spots
        given again among the same tracks by each one's miss in units of its expected miss
        (:meth:`_expected_miss`), where that is clearly better (``REASSIGN_MARGIN``) and one
        of them is a lost track (module docstring); gates and bars hold."""
        if self.config.lost_spread_px <= 0 or len(made) < 2 \
                or not any(self.tracks[r].lost for r, _ in made):
            return made
        base = max(self.config.hold_px, 1.0)
        rows_in = np.array([r for r, _ in made])
        cols_in = np.array([c for _, c in made])
        sub = cost[np.ix_(rows_in, cols_in)]
        weight = base / self._expected_miss(stamp_s)[rows_in]  # 1 for a running track
        norm = np.where(sub <= gate[rows_in][:, None], sub * weight[:, None], BARRED)
        rows, cols = linear_sum_assignment(norm)
        if float(np.trace(norm) - norm[rows, cols].sum()) < REASSIGN_MARGIN * base:
            return made
        return [(int(rows_in[r]), int(cols_in[c])) for r, c in zip(rows, cols, strict=True)]

    def _expected_miss(self, stamp_s: float) -> FloatArray:
        """(tracks,) each track's expected miss of its marker at ``stamp_s`` [px]: ``hold_px``
        (at least 1 px) for a running track, growing for a lost one with the time unseen as
        ``lost_spread_px * (unseen / SPREAD_S) ** SPREAD_POWER`` (added in quadrature): a
        covered marker moves on with the sand, unseen."""
        base = max(self.config.hold_px, 1.0)
        unseen = np.array([stamp_s - t.last_stamp_s if t.lost else 0.0 for t in self.tracks])
        return np.asarray(np.hypot(base, self.config.lost_spread_px
                                   * (unseen / SPREAD_S) ** SPREAD_POWER), np.float64)

    def _out_of_reach(self, stamp_s: float, uv: FloatArray) -> NDArray[np.bool_]:
        """(tracks, n): detections ``uv`` (n, 2) px farther from each track's last position
        than its marker can have moved since (``max_image_speed_px_s``, plus ``SLACK_PX``)."""
        last = np.array([t.uv for t in self.tracks])
        since = np.array([stamp_s - t.last_stamp_s for t in self.tracks])
        reach = self.config.max_image_speed_px_s * since + SLACK_PX
        return np.asarray(np.linalg.norm(last[:, None] - uv[None], axis=2) > reach[:, None],
                          bool)

    def _assign_faint(self, stamp_s: float, det: Detections, linked: set[int],
                      ) -> list[tuple[int, FloatArray]]:
        """(track index, (2,) px) links of the numbered tracks left without a spot to a faint
        spot (below the detector's threshold: ``Detections.faint``) within ``faint_gate_px``
        of each one's prediction; a spot two tracks find is left to neither (a faint spot's
        number is given out only once the other camera confirms it: ``pair_checks.verify``).
        """
        if det.faint is None or self.config.faint_gate_px <= 0:
            return []
        rows = [ti for ti, t in enumerate(self.tracks) if ti not in linked and t.marker >= 0]
        if not rows:
            return []
        decay = self.config.velocity_decay
        pred = np.array([self.tracks[ti].predict(stamp_s, decay) for ti in rows])
        steps = None
        if self.config.exposure_s > 0:  # each marker's motion during the exposure [px]
            steps = np.array([self.tracks[ti].velocity * self.config.exposure_s
                              * (decay ** (stamp_s - self.tracks[ti].last_stamp_s)
                                 if self.tracks[ti].lost else 1.0) for ti in rows])
        spots = det.faint(pred, self.config.faint_gate_px, steps)
        found = [(ti, p) for ti, p in zip(rows, spots, strict=True) if np.isfinite(p).all()]
        keys = [tuple(p.tolist()) for _, p in found]
        return [(ti, p) for (ti, p), key in zip(found, keys, strict=True)
                if keys.count(key) == 1]

    def _advance(self, track: Track, uv: FloatArray, stamp_s: float, events: list[str]) -> None:
        dt = stamp_s - track.last_stamp_s
        miss = float(np.linalg.norm(uv - track.predict(stamp_s, self.config.velocity_decay)))
        track.link_px = max(track.link_px, miss)
        if track.lost:
            self.counts.reattached += 1
            track.reattach_px = max(track.reattach_px, miss)
            track.reattached = (stamp_s, miss)
            track.back_unchecked = True
            events.append(f're-attached track {track.track_id} (marker {track.marker}) after '
                          f'{dt:.3f} s unseen, {np.linalg.norm(uv - track.uv):.1f} px away')
            track.lost = False
            track.velocity = np.zeros(2)
        elif dt > 0:
            track.velocity = (uv - track.uv) / dt
        track.uv = np.array(uv, np.float64)
        track.last_stamp_s = stamp_s
        track.history.append((stamp_s, float(uv[0]), float(uv[1])))

    def number(self, track_id: int, marker: int) -> None:
        """Give a track its marker number (from the grid or the other camera)."""
        for track in self.tracks:
            if track.track_id == track_id:
                if self.on_number is not None and track.marker != marker:
                    self.on_number(track, marker)
                track.marker = marker


def hold_radii(tracks: list[Track], stamp_s: float, config: TrackerConfig) -> FloatArray:
    """(tracks,) each track's hold radius at ``stamp_s`` [px]: ``hold_px``, or
    ``hold_step_share`` of its predicted step (velocity [px/s] times the time since it was
    seen) where larger: a constant velocity misses an accelerating marker by a share of its
    step (module docstring). 0 everywhere when ``hold_px`` is 0 (nothing held)."""
    base = np.full(len(tracks), config.hold_px)
    if config.hold_px <= 0 or config.hold_step_share <= 0 or not tracks:
        return base
    step = np.array([float(np.hypot(*t.velocity)) * (stamp_s - t.last_stamp_s) for t in tracks])
    return np.asarray(np.maximum(base, config.hold_step_share * step), np.float64)


def rival_tracks(tracks: list[Track], stamp_s: float, unseen_s: float,
                 fast: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """(holders, rivals): whether track ``o`` may rival track ``r``'s held link: always, unless
    ``r`` is ``fast`` (its hold radius widened by its step) and ``o`` was unseen for longer than
    ``unseen_s`` [s] before ``stamp_s`` (0: always): around a marker that fast the sand moves
    as fast, and a marker covered that long moved with it unseen, so its track's prediction
    lying near the spot says nothing of whose the spot is."""
    n = len(tracks)
    if unseen_s <= 0 or not n:
        return np.ones((n, n), bool)
    recent = np.array([stamp_s - t.last_stamp_s <= unseen_s for t in tracks], bool)
    return np.asarray(recent[None, :] | ~np.asarray(fast, bool)[:, None], bool)


def held_links(cost: FloatArray, running: NDArray[np.bool_], within_px: float | FloatArray,
               rival_px: float = 0.0, rivals: NDArray[np.bool_] | None = None,
               ) -> list[tuple[int, int]]:
    """The links made before the assignment: (track index, detection index) of each running
    track and detection that are each other's nearest, within the track's ``within_px``, that
    no other rival track predicts within ``rival_px``.

    Args:
        cost: (tracks, detections) distance of each detection from each track's prediction
            [px] (inf: barred).
        running: (tracks,) whether each track was linked in the last frame (not lost).
        within_px: the largest such distance [px], one for all or (tracks,) one per track
            (:func:`hold_radii`); 0: none held.
        rival_px: a detection another track's prediction lies this near is held for none
            [px]; 0: no such test.
        rivals: (tracks, tracks) whether track ``o`` may rival track ``r``'s held link
            (``rivals[r, o]``, :func:`rival_tracks`); None: every other track.
    """
    radius = np.broadcast_to(np.asarray(within_px, np.float64), (len(cost),))
    if not cost.size or not (radius > 0).any():
        return []
    nearest_det = np.argmin(cost, axis=1)
    nearest_track = np.argmin(cost, axis=0)
    held = [(r, int(c)) for r, c in enumerate(nearest_det.tolist())
            if running[r] and nearest_track[c] == r and radius[r] > 0 and cost[r, c] <= radius[r]]
    if rival_px <= 0 or len(cost) < 2:
        return held
    others = np.ones((len(cost), len(cost)), bool) if rivals is None \
        else np.asarray(rivals, bool)
    out = []
    for r, c in held:
        seen = others[r].copy()
        seen[r] = False
        if not seen.any() or cost[seen, c].min() > rival_px:
            out.append((r, c))
    return out


def track_sequence(frames: Iterable[tuple[float, Detections]],
                   config: TrackerConfig | None = None,
                   seed: tuple[FloatArray, NDArray[np.int32], float] | None = None,
                   ) -> tuple[list[TrackFrame], MarkerTracker]:
    """Batch form: run :class:`MarkerTracker` over ``(stamp_s, detections)`` frames."""
    tracker = MarkerTracker(config)
    if seed is not None:
        tracker.seed(*seed)
    return [tracker.update(t, d) for t, d in frames], tracker
