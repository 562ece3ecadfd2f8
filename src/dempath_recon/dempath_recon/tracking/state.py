"""What the two-camera marker tracker keeps between frames: one record, and the small functions
on it that its numbering and checks share.

:class:`StereoState` holds each camera's 2D linker, counts and latest numbered points, the
markers' accepted 3D positions, the fitted grid, and the bookkeeping of numbers given and
refused. It is plain data: the numbering (:mod:`~dempath_recon.tracking.numbering`,
:mod:`~dempath_recon.tracking.pair_numbering`) and the checks
(:mod:`~dempath_recon.tracking.one_camera`, :mod:`~dempath_recon.tracking.pair_checks`) are
functions taking it, and :class:`~dempath_recon.tracking.stereo.StereoMarkerTracker` runs them
in order on every frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import MarkerPositions, back_project, depth
from dempath_recon.tracking.linker import UNNUMBERED, MarkerTracker, Track
from dempath_recon.tracking.number_record import NumberRecord
from dempath_recon.tracking.records import CameraCounts, StereoTrackConfig
from dempath_recon.tracking.release import ReleaseQueue
from dempath_recon.tracking.speed_bound import camera_tracker

FloatArray = NDArray[np.float64]
RECENT_S = 0.05  # the other camera's position of a marker counts for numbering this long [s]
ALONE_RATIO = 3.0  # a re-found spot is kept on one camera's evidence when every other marker
# this camera does not see now would have had to move at least this many times faster to be there
MIN_SPEED_PX_S = 50.0  # speed floor of that comparison: a pixel a frame at 50 FPS [px/s]
CARRY_FLOOR_M = 0.003  # nearest-marker comparison of ``only_marker``: distances below this
# (a few times the triangulation noise, ~1 mm RMS) count as this [m]
MAX_DEPTH_AGE_S = 0.06  # a 3D point older than this (three frames) no longer bounds the depth
# along an epipolar line usefully (the gate has grown to 0.13 m, several marker pitches)

Sighting = tuple[float, FloatArray]  # (stamp s, (2,) px)


@dataclass
class StereoState:
    """The two-camera tracker's state between frames (build it with :meth:`start`).

    Attributes:
        cameras: ``{name: camera}`` for the two cameras (calibrated, world frame).
        config: pipeline settings.
        trackers: each camera's 2D linker.
        counts: what happened to each camera's frames.
        latest: each camera's latest given-out point of each marker.
        positions: the markers' accepted 3D positions.
        last_stamp: each camera's last frame's stamp [s] (None before its first).
        grid_uv: the fitted grid, per camera: marker -> (2,) px.
        grid_time: stamp of the frame each camera's grid was fitted on [s].
        late_numbered: per camera, the tracks numbered after the start (epipolar line, late
            grid, pair): their number is taken back if a later pair contradicts it.
        refused: per camera, (track id, marker) pairs a check ruled out for good.
        pending: withheld points of unconfirmed re-attachments: marker -> sighting.
        grid_unsure: per camera, track id -> the grid number it was left without at the grid
            fit because a spot of the other camera lay on its line
            (``numbering.number_grid_unsure``).
        fit_merged: per camera, track id -> the markers the grid fit refused it as a merged
            spot (two markers along one line of sight); ``track_pairs`` may give one of them
            later, by depth.
        confirmed: per camera, track id -> stamp of the track's last passed pair check [s]
            (a point it withheld before then, unbroken since, goes out numbered).
        free: each camera's last frame's unnumbered tracks: (stamp s, track ids (k,),
            px (k, 2)), None before its first frame.
        queue: the frames held for the publication delay.
        residuals: per camera, each checked frame's median distance of its numbered pairs
            from their epipolar lines [px] (``pair_checks.note_residuals``).
        last_tracks: each camera's last frame's tracks: (stamp s, track ids (k,), px (k, 2)),
            None before its first frame.
        provisional: cameras numbered by their own grid before the other camera's first
            frame; the grid numbering of both cameras at once renumbers them.
        eliminated: per camera, track id -> (stamp of its numbering by elimination [s], its
            largest link miss then [px]) (``grid_elimination``: watched till a pair check
            passes).
        jumped: per camera, track id -> (the number elimination took back from it for a
            jump without a re-attachment, the stamp it was numbered at [s])
            (``grid_elimination.revoke_jumped``; :mod:`~dempath_recon.tracking.regain` may
            give it back).
        crowd_taken: per camera, track id -> (the number a crowded same-instant pair took
            back from it, its clear frames in a row, the stamp the row began at [s])
            (:func:`~dempath_recon.tracking.crowded_pair.give_back` may give it back).
        spot_sizes: per camera, track id -> the radii of gyration of its last spots [px]
            (:mod:`~dempath_recon.tracking.merge_release`: a spot that grew may hold two).
        merge_freed: per camera, the tracks whose number a merge took back, while unnumbered
            (their held points stay unnumbered: ``merge_release.keep_released_free``).
        record: which rule numbered what (``config.record_numbers``; None: not kept).
        ray_wait: per camera, track id -> the markers it may be, a spot one camera showed at
            the grid fit with other markers on its line of sight
            (:mod:`~dempath_recon.tracking.ray_rivals`; numbered once one is left).
    """

    cameras: dict[str, Camera]
    config: StereoTrackConfig
    trackers: dict[str, MarkerTracker]
    counts: dict[str, CameraCounts]
    latest: dict[str, dict[int, Sighting]]
    positions: MarkerPositions
    last_stamp: dict[str, float | None]
    grid_uv: dict[str, dict[int, FloatArray]]
    grid_time: dict[str, float]
    late_numbered: dict[str, set[int]]
    refused: dict[str, set[tuple[int, int]]]
    pending: dict[str, dict[int, Sighting]]
    confirmed: dict[str, dict[int, float]]
    grid_unsure: dict[str, dict[int, int]]
    fit_merged: dict[str, dict[int, set[int]]]
    free: dict[str, tuple[float, NDArray[np.int64], FloatArray] | None]
    queue: ReleaseQueue
    residuals: dict[str, list[float]]
    last_tracks: dict[str, tuple[float, NDArray[np.int64], FloatArray] | None]
    provisional: set[str]
    eliminated: dict[str, dict[int, tuple[float, float]]]
    jumped: dict[str, dict[int, tuple[int, float]]]
    crowd_taken: dict[str, dict[int, tuple[int, int, float]]]
    spot_sizes: dict[str, dict[int, list[float]]]
    merge_freed: dict[str, set[int]]
    record: NumberRecord | None = None
    ray_wait: dict[str, dict[int, set[int]]] = field(default_factory=dict)

    @classmethod
    def start(cls, cameras: dict[str, Camera], config: StereoTrackConfig) -> StereoState:
        """The state before the first frame; ValueError unless there are exactly two cameras."""
        if len(cameras) != 2:
            raise ValueError(f'cameras: need exactly two, got {sorted(cameras)}')
        trackers = {n: MarkerTracker(camera_tracker(config.tracker, cam, config.grid,
                                                    config.tool_speed_m_s,
                                                    config.marker_diameter_m))
                    for n, cam in cameras.items()}
        record = NumberRecord() if config.record_numbers else None
        for n, tracker in trackers.items():
            tracker.on_number = None if record is None else record.hook(n)
        return cls(
            cameras=cameras, config=config, trackers=trackers,
            counts={n: CameraCounts() for n in cameras},
            latest={n: {} for n in cameras},
            positions=MarkerPositions(config.position_gate_m, config.max_speed_m_s),
            last_stamp=dict.fromkeys(cameras), grid_uv={}, grid_time={},
            late_numbered={n: set() for n in cameras}, refused={n: set() for n in cameras},
            pending={n: {} for n in cameras}, confirmed={n: {} for n in cameras},
            grid_unsure={n: {} for n in cameras}, fit_merged={n: {} for n in cameras},
            free=dict.fromkeys(cameras),
            queue=ReleaseQueue(cameras, config.number_delay_frames),
            residuals={n: [] for n in cameras}, last_tracks=dict.fromkeys(cameras),
            provisional=set(), eliminated={n: {} for n in cameras},
            jumped={n: {} for n in cameras}, crowd_taken={n: {} for n in cameras},
            spot_sizes={n: {} for n in cameras}, merge_freed={n: set() for n in cameras},
            record=record)

    def other(self, camera: str) -> str:
        """The other camera's name."""
        return next(n for n in self.cameras if n != camera)


def unnumbered_tracks(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                      markers: NDArray[np.int32]) -> NDArray[np.bool_]:
    """(k,) whether each detection is unnumbered and so is its track (not a withheld point of a
    numbered track)."""
    numbered = {t.track_id for t in state.trackers[camera].tracks if t.marker >= 0}
    return np.array([m == UNNUMBERED and int(t) not in numbered
                     for t, m in zip(track_ids, markers, strict=True)], bool)


def grid_xyz(state: StereoState, camera: str, marker: int) -> tuple[float, FloatArray] | None:
    """``(depth m, (3,) m)``: the marker's fitted grid point in ``camera`` placed at the grid
    point's depth; None when the camera's grid has no such point."""
    grid_uv = state.grid_uv.get(camera, {})
    if marker not in grid_uv:
        return None
    numbers, xyz = state.config.grid.points()
    cam = state.cameras[camera]
    z = depth(cam, xyz[list(numbers).index(marker)])
    return z, back_project(cam, grid_uv[marker], z)


def grid_point(state: StereoState, marker: int) -> tuple[float, FloatArray] | None:
    """``(stamp s, (3,) m)``: a marker's fitted grid point in the first camera whose grid
    was fitted, at the grid point's depth, at that fit's stamp; None before any fit."""
    if not state.grid_time:
        return None
    camera = min(state.grid_time, key=lambda c: state.grid_time[c])
    placed = grid_xyz(state, camera, marker)
    return None if placed is None else (state.grid_time[camera], placed[1])


def carried_point(state: StereoState, marker: int, stamp_s: float,
                  ) -> tuple[FloatArray, float] | None:
    """``((3,) m, since s)``: where the bed has carried a marker by ``stamp_s`` since its last
    accepted 3D position (``MarkerPositions.carried``: moved as its three nearest tracked
    neighbours moved; a marker never triangulated starts from its fitted grid point), and the
    stamp it was last placed at; None when it cannot be placed."""
    # the grid point only for a marker never triangulated (asked of every marker by several
    # rules a frame, it undistorts a pixel each time: 0.1-0.3 ms a frame, session 22)
    known = state.positions.known.get(marker)
    anchor = grid_point(state, marker) if known is None else None
    at = state.positions.carried(marker, stamp_s, 1.5 / state.config.fps, MAX_DEPTH_AGE_S,
                                 anchor)
    if at is None:
        return None
    return at, (known or anchor or (stamp_s, at))[0]


def at_stamp(state: StereoState, camera: str, marker: int, sighting: Sighting,
             stamp_s: float) -> FloatArray:
    """(2,) px: ``camera``'s sighting of ``marker`` moved to ``stamp_s`` along its track.

    The two cameras are not synchronised (the front one exposes a few ms after the side
    one); a marker pushed at 1 m/s moves several pixels in between, which put a right pair
    4 px off the epipolar line on the bundled render re-encoded with a 1 ms shutter (its
    number was taken back for good). The sighting moves with its track's velocity (the last
    link's) when the track is running and was seen at that sighting; otherwise it is kept.
    """
    seen_s, uv = sighting
    for track in state.trackers[camera].tracks:
        if track.marker == marker and not track.lost and track.last_stamp_s == seen_s \
                and len(track.history) > 1:
            return np.asarray(uv + track.velocity * (stamp_s - seen_s), np.float64)
    return uv


def forget_refusals(state: StereoState, camera: str, stamp_s: float) -> None:
    """Forget the numbers refused to a track that re-attached in this frame farther than
    ``doubt_link_px`` from its prediction: a refusal says the marker the track followed is not
    that number, and after such a jump the track may follow another marker (one that reappeared
    beside its covered own). Kept, a refusal made on the old marker's spot would bar the right
    number for good (on the bundled render: the front's track of 8 took 9's spot at frame 1,
    lost number 8 there, and re-attached onto 8's own spot at frame 16)."""
    for track in state.trackers[camera].tracks:
        if track.reattached is not None and track.reattached[0] == stamp_s \
                and track.reattached[1] > state.config.doubt_link_px:
            state.refused[camera] = {r for r in state.refused[camera] if r[0] != track.track_id}


def take_back(state: StereoState, camera: str, track_id: int, number: int) -> None:
    """Take a track's number back for good: it is unnumbered, refuses that number from now on
    (a later numbering may give it another), and the camera counts a revocation."""
    state.refused[camera].add((track_id, number))
    state.trackers[camera].number(track_id, UNNUMBERED)
    state.counts[camera].revoked += 1


def give_late(state: StereoState, camera: str, track: Track, number: int) -> None:
    """Number ``track`` of ``camera`` after the start (a later pair may take it back;
    as :mod:`~dempath_recon.tracking.track_pairs`, :mod:`~dempath_recon.tracking.regain` and
    :func:`~dempath_recon.tracking.crowded_pair.give_back` do)."""
    retire(state, camera, number)
    state.trackers[camera].number(track.track_id, number)
    state.late_numbered[camera].add(track.track_id)
    state.refused[camera].discard((track.track_id, number))


def retire(state: StereoState, camera: str, number: int) -> None:
    """Drop the lost track that held ``number`` (its marker came back as a new track)."""
    tracker = state.trackers[camera]
    tracker.tracks = [t for t in tracker.tracks if not (t.lost and t.marker == number)]


def report(state: StereoState) -> dict[str, Any]:
    """Counts per camera, and the stamp gaps where frames were missing."""
    return {n: dict(vars(c)) for n, c in state.counts.items()}


def sure_numbers(state: StereoState, camera: str, track_ids: NDArray[np.int64],
                 markers: NDArray[np.int32]) -> NDArray[np.int32]:
    """``markers`` without the numbers of tracks re-attached farther than ``doubt_link_px``
    and not confirmed by a pair check since: such a track may have taken another spot, and
    its marker may be elsewhere (the numberings of new spots count it as missing)."""
    doubtful = {t.track_id for t in state.trackers[camera].tracks
                if t.reattached is not None and t.reattached[1] > state.config.doubt_link_px
                and state.confirmed[camera].get(t.track_id, -np.inf) < t.reattached[0]}
    return np.where([int(t) in doubtful for t in track_ids], UNNUMBERED, markers).astype(
        np.int32)
