"""The state the two-camera marker tracker keeps between frames, and the small helpers its
parts share.

:class:`StereoState` holds each camera's tracker, counts and latest numbered points, the markers'
accepted 3D positions, the fitted grid, and the bookkeeping of numbers given and refused. The
tracker's parts are built on it: the one-camera checks (:mod:`dempath_recon.stereo_one_camera`),
the pair checks before anything is given out (:mod:`dempath_recon.stereo_checks`), the numbering
of a marker back in both cameras as a pair (:mod:`dempath_recon.stereo_pairs`), and the
pipeline itself (:class:`dempath_recon.stereo_track.StereoMarkerTracker`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_recon.associate import MarkerPositions, back_project, depth
from dempath_recon.detect import MarkerDetector
from dempath_recon.methods.triangulate import Camera
from dempath_recon.stereo_records import CameraCounts, StereoTrackConfig
from dempath_recon.stereo_release import ReleaseQueue
from dempath_recon.track import UNNUMBERED, MarkerTracker

FloatArray = NDArray[np.float64]
RECENT_S = 0.05  # the other camera's position of a marker counts for numbering this long [s]
ALONE_RATIO = 3.0  # a re-found spot is kept on one camera's evidence when every other marker
# this camera does not see now would have had to move at least this many times faster to be there
MIN_SPEED_PX_S = 50.0  # speed floor of that comparison: a pixel a frame at 50 FPS [px/s]
CARRY_FLOOR_M = 0.003  # nearest-marker comparison of ``_only_marker``: distances below this
# (a few times the triangulation noise, ~1 mm RMS) count as this [m]
MAX_DEPTH_AGE_S = 0.06  # a 3D point older than this (three frames) no longer bounds the depth
# along an epipolar line usefully (the gate has grown to 0.13 m, several marker pitches)


class StereoState:
    """The two-camera tracker's state between frames.

    Args:
        cameras: ``{name: camera}`` for the two cameras (calibrated, world frame).
        config: pipeline settings.
    """

    def __init__(self, cameras: dict[str, Camera], config: StereoTrackConfig | None = None,
                 ) -> None:
        if len(cameras) != 2:
            raise ValueError(f'cameras: need exactly two, got {sorted(cameras)}')
        self.cameras = cameras
        self.config = config or StereoTrackConfig()
        self.detector = MarkerDetector(self.config.detector)
        self.trackers = {n: MarkerTracker(self.config.tracker) for n in cameras}
        self.counts = {n: CameraCounts() for n in cameras}
        self.latest: dict[str, dict[int, tuple[float, FloatArray]]] = {n: {} for n in cameras}
        self.positions = MarkerPositions(self.config.position_gate_m, self.config.max_speed_m_s)
        self._last: dict[str, float | None] = dict.fromkeys(cameras)
        self._grid_uv: dict[str, dict[int, FloatArray]] = {}  # the fitted grid, per camera
        self._late_numbered: dict[str, set[int]] = {n: set() for n in cameras}  # track ids
        self._refused: dict[str, set[tuple[int, int]]] = {n: set() for n in cameras}
        self._grid_time: dict[str, float] = {}  # stamp of the frame each camera's grid fit
        # withheld points of unconfirmed re-attachments: marker -> (stamp s, (2,) px)
        self._pending: dict[str, dict[int, tuple[float, FloatArray]]] = {n: {} for n in cameras}
        # each camera's last frame's unnumbered tracks: (stamp s, track ids (k,), px (k, 2))
        self._free: dict[str, tuple[float, NDArray[np.int64], FloatArray] | None] = \
            dict.fromkeys(cameras)
        self._queue = ReleaseQueue(cameras, self.config.number_delay_frames)

    def other(self, camera: str) -> str:
        """The other camera's name."""
        return next(n for n in self.cameras if n != camera)

    def _unnumbered_tracks(self, camera: str, track_ids: NDArray[np.int64],
                           markers: NDArray[np.int32]) -> NDArray[np.bool_]:
        """(k,) whether each detection is unnumbered and so is its track (not a withheld
        point of a numbered track)."""
        numbered = {t.track_id for t in self.trackers[camera].tracks if t.marker >= 0}
        return np.array([m == UNNUMBERED and int(t) not in numbered
                         for t, m in zip(track_ids, markers, strict=True)], bool)

    def _grid_xyz(self, camera: str, marker: int) -> tuple[float, FloatArray] | None:
        """``(depth m, (3,) m)``: the marker's fitted grid point in ``camera`` placed at the
        grid point's depth; None when the camera's grid has no such point."""
        grid_uv = self._grid_uv.get(camera, {})
        if marker not in grid_uv:
            return None
        numbers, xyz = self.config.grid.points()
        cam = self.cameras[camera]
        z = depth(cam, xyz[list(numbers).index(marker)])
        return z, back_project(cam, grid_uv[marker], z)

    def _forget_refusals(self, camera: str, stamp_s: float) -> None:
        """Forget the numbers refused to a track that re-attached in this frame farther than
        ``doubt_link_px`` from its prediction: a refusal says the marker the track followed is
        not that number, and after such a jump the track may follow another marker (one that
        reappeared beside its covered own). Kept, a refusal made on the old marker's spot would
        bar the right number for good (on the bundled render: the front's track of 8 took 9's
        spot at frame 1, lost number 8 there, and re-attached onto 8's own spot at frame 16)."""
        for track in self.trackers[camera].tracks:
            if track.reattached is not None and track.reattached[0] == stamp_s \
                    and track.reattached[1] > self.config.doubt_link_px:
                self._refused[camera] = {r for r in self._refused[camera]
                                         if r[0] != track.track_id}

    def _retire(self, camera: str, number: int) -> None:
        """Drop the lost track that held ``number`` (its marker came back as a new track)."""
        tracker = self.trackers[camera]
        tracker.tracks = [t for t in tracker.tracks if not (t.lost and t.marker == number)]

    def report(self) -> dict[str, Any]:
        """Counts per camera, and the stamp gaps where frames were missing."""
        return {n: {k: v for k, v in vars(c).items()} for n, c in self.counts.items()}
