"""Marker detection in colour frames with sub-pixel centres (Crocker-Grier style).

The paper's markers are clay spheres whose colour contrasts with sand. A marker is found where
the illumination-invariant chroma ``(B - R) / (B + G + R)`` (positive for blue clay, negative
for yellow-brown sand, unchanged by shadows, gain and gradients because both terms scale with
the light) is high:

1. decode (optionally at half size: libjpeg-turbo scales in the DCT domain, which halves the
   decode time; JPEG's chroma is stored at half resolution anyway), through ``simplejpeg``
   (libjpeg-turbo; about 40 % less time than OpenCV's ``imdecode`` for the same half-size
   image, which goes through OpenCV's general codec layer), OpenCV for other formats;
2. find the window that can hold markers (pixels bluer than the chroma threshold allows at
   the least, by a byte subtraction) and compute the chroma image only there (the
   full-frame chroma was the largest cost of the detection, and the markers cover a small
   part of the view); the detections are those of the whole frame;
3. a Gaussian matched to the marker's image (Crocker & Grier 1996, sec. 2: band-pass then local
   maxima), applied to the chroma floored at the sand the threshold assumes (``FILTER_FLOOR``:
   sand redder than that must not pull a small spot's peak further down), and local maxima
   at least ``min_separation_px`` apart above ``threshold``; in a frame in normal light (the
   default ``DetectorConfig.band_pass``) the filter less the chroma's local background, and a
   spot the filter alone would not pass kept only where its excess chroma says at least half
   a marker is seen (:mod:`~dempath_recon.tracking.band_pass`);
4. the centre by an intensity-weighted centroid of the chroma above ``threshold / 2`` in a
   circular window, re-centred until it moves less than 0.01 px (Crocker & Grier's iteration),
   which reaches well below 0.1 px on clean spots;
5. in a dim frame (dusk, a short shutter: the frame's own chroma floor under ``MIN_SUM_DN``),
   the markers' neighbourhood searched again on the chroma floored at the frame's own light
   (``DetectorConfig.dim_spots``, :meth:`MarkerDetector._dim_spots`).

Pixel convention (dempath and OpenCV): integer coordinates at pixel centres; a half-size pixel
``i`` covers full-size pixels ``2i`` and ``2i + 1``, so its centre is at ``2i + 0.5``.

Reference: J. C. Crocker, D. G. Grier, "Methods of digital video microscopy for colloidal
studies", J. Colloid Interface Sci. 179 (1996) 298-310.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache, partial
from typing import Any, NamedTuple, Protocol

import cv2
import numpy as np
import simplejpeg
from numpy.typing import NDArray

from dempath_recon.errors import ReconstructionError
from dempath_recon.tracking.band_pass import (
    BAND_THRESHOLD,
    MASS_REACH,
    band_square,
    excess_mass,
    kept_spots,
    local_background,
)
from dempath_recon.tracking.centroid_kernel import refine_centroids
from dempath_recon.tracking.centroid_kernel import warm as warm_centroids
from dempath_recon.tracking.colour_model import (
    DARK_SUM_DN,
    MIN_SUM_DN,
    REFERENCE_SAND_BGR,
    ChromaParts,
    axis_bound,
    axis_numerator,
    axis_parts,
    blue_parts,
    bright_peaks,
    chroma_floor,
    clay_bar,
    colour_axis,
    frame_axis,
    is_blue,
    lit_peaks,
)
from dempath_recon.tracking.contrast_faint import ISOLATION, contrast_spot, whole_excess
from dempath_recon.tracking.covered import MAX_ELEVATION_DEG, seen_share, uncover
from dempath_recon.tracking.cut_discs import fit_cut_discs
from dempath_recon.tracking.cut_discs_kernel import warm as warm_cut_discs
from dempath_recon.tracking.seen_flux import spot_flux
from dempath_recon.tracking.shaded import lit_centroids, shade_floor
from dempath_recon.tracking.split import GAIN, split_touching
from dempath_recon.tracking.streak import STREAK_MIN_PX, find_streak

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
CROWDED_SIZE = 0.38  # a spot whose radius of gyration exceeds this share of a marker's diameter
# holds two markers the splitting did not part (single markers on the tuning renders: at most
# 0.39, 99 % below 0.35; touching pairs left whole: 0.38-0.45)
TYPICAL_SIZE = 0.29  # a lone marker's radius of gyration as a share of its diameter (median on
# the tuning renders 0.29, the bundled render 0.27)
MIN_SPOTS = 5  # spots a frame needs for its median size to count
DIM_REACH = 6.0  # the dim pass searches the box of the frame's spots grown by this many marker
# diameters [-]: two grid pitches (25 mm pitch, 8 mm markers), where a marker the fixed floor
# missed lies among or beside the found ones; the whole frame cost 2-3 times the detection
# (the chroma, the filter and blob fits over a frame whose sand passes the lowered byte bound)
# and its spots off every marker lay 100-270 px from the markers (dusk on a darker sand, tuning)
# MIN_SUM_DN (colour_model): below this B + G + R (mean 20 grey levels) the chroma of a frame in
# normal light is mostly noise. DARK_SUM_DN (colour_model): the chroma's floor in the local search
# beside a track's prediction, whose bar is set by the window's measured noise: at dusk a marker
# in shadow sums 25-60 (light x0.28, session 16), where ``MIN_SUM_DN`` divided its chroma by up
# to 2.4 and it fell under any bar (``DetectorConfig.exposure_floor`` lowers the frame's floor)
FILTER_FLOOR = -0.2  # the matched filter sees sand no redder than the sand the threshold
# assumes (0.15 is the midpoint between sand at -0.2 and clay at +0.5): reddish sand (-0.3) pulled
# a small spot's filtered peak down by that much more, so a half-buried marker (a strip 2-3 px
# high) passed on yellow sand and was lost on reddish sand (filtered peak 0.05 from a raw 0.38;
# session 15). A floor at grey (0) found more markers under half visible too, and the trackers
# then jumped onto them: more switches and wrong pairs on 5 of 13 tuning looks


CENTRE_SMOOTH = 0.7  # the published centres' Gaussian as a share of the matched filter's
# (``DetectorConfig.smooth_centres``; 1 px at half size): on the tuned variations' whole, lone
# markers the centres' error fell 0.351 -> 0.329 px as rendered, 0.711 -> 0.625 px under JPEG
# 60 with noise 6, 0.392 -> 0.369 px on reddish sand; 0.5 took half of that off, 1.0 more
# under noise (0.598 px) but less as rendered (0.338) and on reddish sand (0.390) (session 24)
SPARSE_BOX = 0.1  # a byte-bound box over this share of the frame is narrowed to the pixels
# whose chroma passes (``MarkerDetector._exact_box``)
PEAK_TILE = 32  # candidate pixels in touching tiles of this size [detector px] are filtered
# together (the matched filter's reach is 8-11 px at half size): another clay's dark corners
# spread the candidates' box over half the frame on red clay on slate sand (session 21)
MAX_PEAK_GROUPS = 8  # more clusters than this are filtered in one box (a dusk frame of red clay
# on slate sand: 42 clusters of noise a frame, 2.9 ms apart against 2.6 ms in one box; the
# markers and the dark corners of red clay on slate in daylight: 3-5)


def candidate_groups(rows: NDArray[np.integer[Any]], cols: NDArray[np.integer[Any]],
                     tile: int) -> list[NDArray[np.intp]]:
    """Indices into ``rows``, ``cols`` (n,) [px] of the clusters of pixels that lie in
    8-connected occupied ``tile`` x ``tile`` tiles, each cluster in the pixels' order: pixels
    far apart are filtered in small boxes, not one box that spans them all (any grouping
    gives each pixel the same filtered value; this one only saves work)."""
    ty, tx = np.asarray(rows) // tile, np.asarray(cols) // tile
    grid = np.zeros((int(ty.max()) + 1, int(tx.max()) + 1), np.uint8)
    grid[ty, tx] = 1
    count, labels = cv2.connectedComponents(grid, connectivity=8)
    if count <= 2:
        return [np.arange(len(rows))]
    of = labels[ty, tx]
    order = np.argsort(of, kind='stable')
    cuts = np.flatnonzero(np.diff(of[order])) + 1
    return [np.asarray(g, np.intp) for g in np.split(order, cuts)]



def neighbourhood_max(image: NDArray[Any], rows: NDArray[np.intp], cols: NDArray[np.intp],
                      reach: tuple[NDArray[np.intp], NDArray[np.intp]]) -> NDArray[np.float32]:
    """(n,) the greatest value of ``image`` (h, w) over each pixel's (``rows``, ``cols`` (n,))
    neighbourhood, the offsets ``reach`` (row and column offsets (m,) each: an ellipse's
    pixels): ``cv2.dilate(image, ellipse)`` read at those pixels only.

    The local-maximum test needs the dilation at the candidate pixels alone (a few hundred a
    frame), where ``cv2.dilate`` ran over the whole filtered box (the whole frame on red clay
    at dusk: 1 ms a frame, session 22). Offsets past the edge are clipped onto it: an ellipse
    holds every offset nearer the centre along each axis, so a clipped neighbour is still a
    neighbour, and the result equals the dilation's (which ignores pixels off the image)."""
    h, w = image.shape
    y = np.clip(np.asarray(rows, np.intp)[:, None] + reach[0][None], 0, h - 1)
    x = np.clip(np.asarray(cols, np.intp)[:, None] + reach[1][None], 0, w - 1)
    return np.asarray(image[y, x].max(axis=1), np.float32)


@cache
def warm_kernels() -> None:
    """Load the detector's compiled kernels (centroids, the cut-disc fit) once per process, when
    the first detector is made: numba's first call sets up its typing (0.2-0.35 s of CPU), which
    a live detector would otherwise spend on its first frame. The fit's own call is made too:
    it hands the kernel a read-only pixel grid, another specialisation than ``warm``'s, which
    numba compiled (0.65 s on an empty cache) or loaded at the first touching pair (session 22).
    """
    warm_centroids()
    warm_cut_discs()
    fit_cut_discs(np.zeros((5, 5), np.float32), (0, 0), np.array([[2.0, 2.0]]), 1.5)


def dim(image: NDArray[np.uint8], below: float = MIN_SUM_DN) -> bool:
    """Whether most of ``image`` (a window beside a prediction) is darker than ``below``
    (median ``B + G + R`` [DN]; by default the chroma's floor ``MIN_SUM_DN``): there the floor
    divides a marker's chroma down, and the fixed bar is the wrong bar."""
    total = np.asarray(cv2.transform(image, np.ones((1, 3), np.float32)), np.float32)
    return bool(np.median(total) < below)


class FaintSearch(Protocol):
    """``Detections.faint``: spots below the threshold near given points (see there)."""

    def __call__(self, points: FloatArray, radius_px: float,
                 steps: FloatArray | None = None) -> FloatArray: ...


class ChromaPatch(Protocol):
    """``Detections.patch``: the detector's chroma around a point (see there)."""

    def __call__(self, point: FloatArray, half_px: float,
                 ) -> tuple[NDArray[np.float32], tuple[int, int]]: ...


class ImageDecodeError(ReconstructionError):
    """An image (JPEG or raw) cannot be decoded; the frame is counted and skipped."""


class Detections(NamedTuple):
    """Markers found in one frame.

    Attributes:
        uv: (n, 2) centres [px] in full-size image coordinates.
        confidence: (n,) 0..1, from the chroma contrast of the spot.
        size_px: (n,) radius of gyration of the spot [px] (full size).
        crowded: (n,) whether the spot is larger than one marker (two touching markers the
            splitting did not part, its centre between them), or None (not known).
        faint: ``faint(points, radius_px, steps=None)``: for each point (k, 2) [px], the centre
            of the strongest spot within ``radius_px`` of it whose filtered peak lies between
            ``faint_threshold`` and the threshold, NaN where none (None: not searched); where
            ``steps`` (k, 2) [px] gives a point's motion during the exposure of at least
            ``STREAK_MIN_PX``, the streak along it instead (:mod:`~dempath_recon.tracking.
            streak`: a long shutter smears a fast marker under any threshold). Never
            markers on their own: the linker lets a numbered track whose marker is missing
            take one beside its prediction (a half-buried marker in a dark, noisy frame,
            ``MarkerTracker``). Searched only there, on demand: the whole frame at the lower
            threshold cost 3.5 ms a frame.
        centre: (n, 2) each spot's marker centre as published [px]: a partly covered
            marker's disc centre rather than the middle of its visible part
            (``DetectorConfig.up_px``, :mod:`~dempath_recon.tracking.covered`), or None: ``uv``.
            Tracking and numbering use ``uv`` (what was measured); only the published points
            take ``centre``.
        parted: (n,) whether each spot is one marker of a blob the detector split into
            touching markers (:mod:`~dempath_recon.tracking.split`), or None (no splitting):
            its centre comes from a fit of the blob, not from a spot of its own.
        patch: ``patch(point, half_px)``: the chroma the detector measured its spots on, in
            the square of half-width ``half_px`` [full-size px] around ``point`` (2,)
            [full-size px], at the detector's scale, and the square's corner ``(x0, y0)``
            [detector px]; or None (not kept). The two-camera tracker refits a spot there
            where its tracks say it holds two markers (:mod:`~dempath_recon.tracking.
            track_split`); computed only when asked.
        flux_shift: (n, 2) how far each spot's ``centre`` moves with its seen share read from
            its chroma flux (``DetectorConfig.flux_share``) [px], or None (not given); the
            tracker applies it to the published points after the whole pass's numbering.
    """

    uv: FloatArray
    confidence: FloatArray
    size_px: FloatArray
    crowded: NDArray[np.bool_] | None = None
    faint: FaintSearch | None = None
    centre: FloatArray | None = None
    parted: NDArray[np.bool_] | None = None
    patch: ChromaPatch | None = None
    mass: FloatArray | None = None
    flux_shift: FloatArray | None = None

    @classmethod
    def empty(cls) -> Detections:
        """No marker."""
        return cls(np.zeros((0, 2)), np.zeros(0), np.zeros(0))


def own_detections(det_uv: FloatArray, uv: FloatArray) -> NDArray[np.intp]:
    """(k,) the index into ``det_uv`` (n, 2) px of the detection each point ``uv`` (k, 2) px
    is, matched exactly (the linker gives out a detection's own centre); -1 for a point on no
    detection (a faint spot)."""
    index = {tuple(p): i for i, p in enumerate(np.asarray(det_uv).tolist())}
    return np.array([index.get(tuple(p), -1) for p in np.asarray(uv).tolist()], np.intp)


@dataclass(frozen=True)
class DetectorConfig:
    """Settings of the marker detector.

    Attributes:
        downscale: 1 (full size) or 2 (decode and detect at half size).
        threshold: chroma a marker's filtered peak must exceed [-] (sand is about -0.2, blue
            clay about +0.5: the midpoint between them).
        sigma_px: Gaussian of the matched filter [full-size px] (about the marker radius / 2).
        window_px: radius of the centroid window [full-size px] (a bit more than the radius).
        min_separation_px: closest two markers may be [full-size px].
        max_markers: keep at most this many spots (the strongest).
        faint_threshold: spots whose filtered peak lies between this and the threshold are
            reported apart (``Detections.faint``) [-]; 0: not searched.
        marker_diameter_px: a marker's expected diameter in the image [full-size px] (from the
            calibration and the markers' depth: ``StereoMarkerTracker`` sets it per camera);
            blobs larger than one marker are split into the touching markers they hold
            (:mod:`~dempath_recon.tracking.split`). 0: no splitting.
        local_bar: where the faint search finds no spot beside a track's prediction and the
            window there is dim (median ``B + G + R`` under ``MIN_SUM_DN``), it looks again
            with a bar set by that window's own noise (its sand's median chroma plus
            ``streak.STREAK_NOISE_K`` robust deviations of the filtered window) on the chroma
            floored at ``DARK_SUM_DN`` (:func:`~dempath_recon.tracking.streak.find_streak`
            with no motion): a marker in shadow at dusk keeps its colour but not the
            brightness the frame-wide ``MIN_SUM_DN`` assumes. Only where dim: the same search
            in every window numbered more on the variations (held out 92.5 -> 95.1 %) but
            raised switches on 6 of 23 tuning looks (105 -> 126) and wrong pairs (32 -> 34;
            session 16). False: the fixed bar only.
        floor_sand: the matched filter sees the chroma floored at ``FILTER_FLOOR`` (the sand
            the threshold assumes), so a spot's filtered peak on redder sand is as on the sand
            the threshold was set for; False: the raw chroma, as before session 15, where a
            marker half buried on reddish sand (chroma -0.3) fell below the threshold after
            smoothing.
        up_px: the image direction of world up at the markers (a unit vector, from the
            calibration: ``StereoMarkerTracker`` sets it per camera). A partly covered marker's
            centroid (the middle of its visible part, up the image from its centre) is moved to
            its disc's centre (:mod:`~dempath_recon.tracking.covered`); needs
            ``marker_diameter_px``. (0, 0): centroids as found.
        view_elevation_deg: the line of sight's elevation above the sand at the markers
            [degrees] (from the calibration, with ``up_px``): how far up a covered marker's
            visible part lies depends on it (side-on a chord hides it, from above a ring).
        cut_split: a blob split into touching markers is fitted with discs each cut by the
            sand in front of it along ``up_px`` (:mod:`~dempath_recon.tracking.cut_discs`), in
            views up to ``covered.MAX_ELEVATION_DEG``; False (or no ``up_px``): whole discs.
        split_wide: blobs wider than one marker (radius of gyration over
            ``split.WIDE_SIZE`` diameters) are tried as several markers too, not only those
            larger than ``split.AREA_RATIO`` markers or holding two peaks.
        marker_bgr: the markers' clay albedo (B, G, R, 0..1 each) when it is not blue: the
            chroma then runs along the line from the sand's colour to the clay's, scaled so
            that the clay reads ``CLAY_CHROMA`` (+0.5) and the sand ``SAND_CHROMA`` (-0.2) as
            blue clay does on ``(B - R) / (B + G + R)``
            (:func:`~dempath_recon.tracking.colour_model.colour_axis`): red, orange or green
            clay is found with the same threshold. None: blue clay, ``(B - R) / (B + G + R)``
            (the default, as tuned).
        sand_bgr: the sand's albedo (B, G, R, 0..1) the axis of ``marker_bgr`` starts from;
            None: each frame's sand as the camera sees it, its median chromaticity
            (:func:`~dempath_recon.tracking.colour_model.frame_axis`: the light's tint and
            the camera's white balance move the sand's colour, the clay's albedo does not say
            it). Not used for blue clay.
        exposure_floor: where the chroma's denominator is floored at a share of the frame's
            median ``B + G + R`` (between ``DARK_SUM_DN`` and ``MIN_SUM_DN``,
            :func:`~dempath_recon.tracking.colour_model.chroma_floor`) rather than at
            ``MIN_SUM_DN``, so that a dusk frame's markers (B + G + R 25-45) keep their chroma
            (frames whose sand sums to 100 or more are unchanged either way): 'faint' (the
            default) in the faint search beside a numbered track's prediction only; 'off':
            ``MIN_SUM_DN`` everywhere. (A second search of dim frames on a floor from the bed
            around each pixel, 'bed', numbered more but added switches and wrong pairs; it
            was removed in session 20: docs/reconstruction.md.)
        shade_centres: in a dim frame (the frame's own chroma floor under the detection's) the
            published centres (``Detections.centre``) are centroids on the chroma floored at
            the frame's light, so a marker's shaded side keeps its weight
            (:mod:`~dempath_recon.tracking.shaded`); False: the detection's centroids.
        dim_spots: in a dim frame, markers the fixed floor divided under the threshold are
            looked for again on the chroma floored at the frame's own light (its exposure,
            ``chroma_floor``), in the box of the frame's spots grown by ``DIM_REACH``
            diameters, at the same threshold; spots farther than a marker's diameter from every
            spot of the fixed floor are added, each as one marker (not split: a dim spot beside
            a found one is that one's rim or an unsure neighbour). The spots of the fixed floor
            are kept as they are (their centres, sizes and splits: the trackers' margins were
            tuned on them; the whole frame on the lowered floor, ``exposure_floor='all'`` of
            session 17, found sand in vignetted corners and moved those margins). Frames in
            normal light are not touched. Off by default (session 23, track41: numbered right
            at dusk up, identity switches up too: docs/figures.md). False: the fixed floor's
            spots only.
        band_pass: a spot is a local maximum of the matched filter less the local background
            above ``band_pass.BAND_THRESHOLD`` among the pixels over the threshold (Crocker and
            Grier's band-pass, :mod:`~dempath_recon.tracking.band_pass`), and one the filter
            alone would not pass (its peak under half the threshold) is kept only where its
            excess chroma says at least ``band_pass.MIN_SHARE`` of a marker is seen: a colour
            cast or a JPEG's blocky chroma lowers a marker's chroma, not its contrast above the
            sand around it. Needs ``marker_diameter_px`` for the share (without it, only
            the fixed rule's spots). Frames in normal light only (the frame's own chroma floor
            at ``MIN_SUM_DN``): in a dim frame the fixed floor divides the chroma of sand and
            markers by a constant rather than their own light (on two burnt dusk looks it
            added 2-7 identity switches). False: the filter alone, its peak over half the
            threshold at a pixel over the threshold.
        smooth_centres: the published centres (``Detections.centre``) of a frame in normal
            light are iterated centroids of the chroma smoothed by a light Gaussian
            (``CENTRE_SMOOTH``, :meth:`MarkerDetector._smooth_centroids`): less of the
            chroma's noise (JPEG, read noise) in them. The spots, their ``uv`` and so the
            trackers are unchanged. Needs ``marker_diameter_px``. False: the centroids of
            the chroma as measured.
        split_gain: a blob is split into ``k + 1`` touching markers only where their fit's
            squared residual is this many times lower than ``k``'s (``split.GAIN``, 2, as
            tuned in session 16; ``split.EAGER_GAIN`` with ``StereoTrackConfig.
            eager_split``).
        flux_share: also give each partly covered marker's centre with its seen share read
            from its chroma flux over the local sand (:func:`~dempath_recon.tracking.
            seen_flux.spot_flux`, linear in the area seen) instead of its centroid mass (the
            chroma above the core level, which drops the blurred rim), as the change it makes
            (``Detections.flux_shift``); ``centre`` stays the mass's. Needs ``up_px``.
            False: not given.
        band_adds_only: with ``band_pass``, a local maximum the fixed rule passes (the
            filter alone over half the threshold) is kept whatever its band-passed value: the
            band-pass adds spots, never takes one of the fixed rule's away. Bunched markers
            raise each other's local background (the square of ``band_pass.BAND_WIDTH``
            diameters holds their clay), and a half-covered one beside them fell under
            ``BAND_THRESHOLD`` where the fixed rule kept it (a grey-sand look, another clay:
            filtered 0.15-0.17, band-passed 0.12-0.14, a neighbour one diameter away). False:
            the band-pass's bar for every spot (as in session 24).
        contrast_faint: the faint search beside a numbered track's prediction, in a window in
            normal light where the fixed bars found nothing, finds a marker by its contrast to
            the window's own sand (a constant false-alarm bar on the matched filter, as
            ``local_bar`` in a dim window), kept only farther than ``contrast_faint.
            ISOLATION`` diameters from the frame's spots and showing ``contrast_faint.
            FAINT_SHARE`` of a whole marker's excess chroma
            (:mod:`~dempath_recon.tracking.contrast_faint`): JPEG and noise flatten a marker
            under any absolute bar, not its contrast to the sand around it. Needs
            ``band_pass`` and ``marker_diameter_px``. On by default (session 26: the tuned
            variations 97.7 -> 99.3 % numbered right). False: the fixed bars only there.
    """

    downscale: int = 2
    threshold: float = 0.15
    sigma_px: float = 2.0
    window_px: float = 6.0
    min_separation_px: float = 6.0
    max_markers: int = 64
    marker_diameter_px: float = 0.0
    faint_threshold: float = 0.08
    floor_sand: bool = True
    up_px: tuple[float, float] = (0.0, 0.0)
    view_elevation_deg: float = 0.0
    local_bar: bool = True
    cut_split: bool = True
    split_wide: bool = True
    marker_bgr: tuple[float, float, float] | None = None
    sand_bgr: tuple[float, float, float] | None = None
    exposure_floor: str = 'faint'
    shade_centres: bool = True
    dim_spots: bool = False
    band_pass: bool = True
    smooth_centres: bool = False
    split_gain: float = GAIN
    flux_share: bool = False
    band_adds_only: bool = False
    contrast_faint: bool = True

    def __post_init__(self) -> None:
        checks = {'downscale': self.downscale in (1, 2), 'threshold': 0 < self.threshold < 1,
                  'sigma_px': 0 < self.sigma_px < 50, 'window_px': 1 <= self.window_px < 100,
                  'min_separation_px': 1 <= self.min_separation_px < 200,
                  'max_markers': self.max_markers >= 1,
                  'faint_threshold': 0 <= self.faint_threshold <= self.threshold,
                  'marker_diameter_px': 0 <= self.marker_diameter_px < 200,
                  'up_px': len(self.up_px) == 2 and bool(np.isfinite(self.up_px).all())
                  and (tuple(self.up_px) == (0.0, 0.0)
                       or abs(float(np.hypot(*self.up_px)) - 1) < 1e-6),
                  'view_elevation_deg': 0 <= self.view_elevation_deg <= 90,
                  'exposure_floor': self.exposure_floor in ('off', 'faint'),
                  'split_gain': 1 < self.split_gain < 100}
        for name, ok in checks.items():
            if not ok:
                msg = f'{name}: out of range, got {getattr(self, name)!r}'
                raise ValueError(msg)
        colour_axis(self.marker_bgr, REFERENCE_SAND_BGR if self.sand_bgr is None
                    else self.sand_bgr)  # a ValueError naming a bad colour

    def colour_name(self) -> str:
        """What the detector looks for, for messages: 'blue clay' or the clay's albedo."""
        if self.marker_bgr is None:
            return 'blue clay markers (chroma (B - R) / (B + G + R)'
        bgr = ','.join(f'{c:g}' for c in self.marker_bgr)
        return f'markers of clay albedo B,G,R {bgr} (chroma along the sand-to-clay axis'


def decode_jpeg(data: bytes | NDArray[np.uint8], downscale: int = 1) -> NDArray[np.uint8]:
    """A BGR image (h, w, 3) from JPEG/PNG bytes, at full or half size.

    Raises:
        ImageDecodeError: the bytes are not a decodable image.
    """
    buf = np.frombuffer(data, np.uint8) if isinstance(data, bytes | bytearray) else data
    if buf.size > 2 and buf[0] == 0xFF and buf[1] == 0xD8:  # a JPEG's start-of-image mark
        try:  # strict: a truncated or damaged JPEG is an error, not a half-grey frame
            h, w = simplejpeg.decode_jpeg_header(buf)[:2]
            # the smallest of libjpeg's DCT scales (1/8 steps) at least 1/downscale of the size
            return np.asarray(simplejpeg.decode_jpeg(buf, 'BGR', min_height=-(-h // downscale),
                                                     min_width=-(-w // downscale)), np.uint8)
        except ValueError as err:
            msg = f'{buf.size}-byte image: not a decodable JPEG ({err})'
            raise ImageDecodeError(msg) from err
    flag = cv2.IMREAD_REDUCED_COLOR_2 if downscale == 2 else cv2.IMREAD_COLOR
    img = cv2.imdecode(buf, flag) if buf.size else None
    if img is None:
        msg = f'{buf.size}-byte image: not a decodable JPEG/PNG'
        raise ImageDecodeError(msg)
    return np.asarray(img, np.uint8)


def chroma(image: NDArray[np.uint8], min_sum: float = MIN_SUM_DN,
           axis: NDArray[np.float32] | None = None) -> NDArray[np.float32]:
    """(h, w) float32 ``(B - R) / max(B + G + R, min_sum)`` of a BGR image, or with ``axis``
    (3,) B, G, R weights ``(axis . [B, G, R]) / max(B + G + R, min_sum)`` (another clay's
    colour, :func:`~dempath_recon.tracking.colour_model.colour_axis`).

    The floor keeps dark pixels (deep shadow, vignetted corners), where the ratio would be
    sensor noise, near zero (``MIN_SUM_DN`` for the frame-wide fixed threshold in normal light,
    lower in a dark frame: :func:`~dempath_recon.tracking.colour_model.chroma_floor`; the local
    search beside a track's prediction measures the noise instead and floors at
    ``DARK_SUM_DN``).
    """
    return chroma_parts(image, axis).floored(min_sum)


def chroma_parts(image: NDArray[np.uint8], axis: NDArray[np.float32] | None = None,
                 ) -> ChromaParts:
    """The numerator and ``B + G + R`` of :func:`chroma` (before its floor), of blue clay or
    of ``axis`` (3,)."""
    if axis is not None and not is_blue(axis):
        return axis_parts(image.astype(np.float32), axis)
    return blue_parts(image)


class MarkerDetector:
    """Finds marker centres in BGR frames (one frame at a time; no state between frames).

    Args:
        config: detector settings.
    """

    def __init__(self, config: DetectorConfig | None = None) -> None:
        self.config = config or DetectorConfig()
        warm_kernels()
        s = self.config.downscale
        self._sigma = self.config.sigma_px / s
        self._radius = self.config.window_px / s
        sep = max(1, round(self.config.min_separation_px / s))
        self._kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * sep + 1, 2 * sep + 1))
        ky, kx = np.nonzero(self._kernel)
        self._reach = (np.asarray(ky, np.intp) - sep, np.asarray(kx, np.intp) - sep)
        r = int(np.ceil(self._radius)) + 1
        yy, xx = np.mgrid[-r:r + 1, -r:r + 1].astype(np.float64)
        self._offsets = (xx, yy)
        # how far the window of a frame's candidates reaches past them [detector px]: the
        # local-maximum filter, the Gaussian, the centroid window and its re-centring
        self._diameter = max(self.config.marker_diameter_px,
                             self.config.min_separation_px) / s  # [detector px]
        # the band-pass's background square [detector px] (0: no band-pass)
        self._band = band_square(self._diameter) if self.config.band_pass else 0
        # the faint search's contrast spots (``contrast_faint``): needs the band-pass's square
        # and a marker size for the share of a whole marker
        self._contrast = (self.config.contrast_faint and self.config.band_pass
                          and self.config.marker_diameter_px > 0)
        self._pad = (int(np.ceil(4 * self._sigma)) + self._kernel.shape[0] // 2
                     + 2 * r + 4 + self._band // 2)
        # the up direction the split's discs are cut along (low views only, as ``covered``)
        cfg = self.config
        self._cut_up = (np.asarray(cfg.up_px, np.float64) if cfg.cut_split
                        and tuple(cfg.up_px) != (0.0, 0.0)
                        and cfg.view_elevation_deg <= MAX_ELEVATION_DEG else None)

    @property
    def cut_up(self) -> FloatArray | None:
        """(2,) the image direction of world up the split's discs are cut along, or None
        (whole discs)."""
        return self._cut_up

    def detect_jpeg(self, data: bytes | NDArray[np.uint8]) -> Detections:
        """Decode JPEG bytes (at the configured scale) and detect."""
        return self.detect(decode_jpeg(data, self.config.downscale), prescaled=True)

    def detect(self, image: NDArray[np.uint8], prescaled: bool = False) -> Detections:
        """Markers in a BGR image (full size, or already at the detector's scale)."""
        s = self.config.downscale
        if s == 2 and not prescaled:
            image = np.asarray(cv2.resize(image, (image.shape[1] // 2, image.shape[0] // 2),
                                          interpolation=cv2.INTER_AREA), np.uint8)
        mode = self.config.exposure_floor
        frame_floor = MIN_SUM_DN if mode == 'off' else chroma_floor(image)
        axis = frame_axis(image, self.config.marker_bgr, self.config.sand_bgr)
        thr = self.config.threshold
        found = self._spots(image, MIN_SUM_DN, axis, thr=thr, frame_floor=frame_floor,
                            dark_bar=clay_bar(image, axis))
        if self.config.dim_spots and frame_floor < MIN_SUM_DN and len(found.uv):
            found = self._dim_spots(image, found, frame_floor, axis)
        found = found._replace(patch=partial(self._patch, image, axis))
        low = min(self.config.faint_threshold, thr)
        if low <= 0:
            return found
        whole = cache(partial(self._whole_excess, image, axis, found.uv))
        return found._replace(faint=partial(self._faint, image, low, (frame_floor, axis),
                                            found.uv, whole=whole))

    def _dim_spots(self, image: NDArray[np.uint8], found: Detections, floor: float,
                   axis: NDArray[np.float32]) -> Detections:
        """``found`` (the fixed floor's spots of ``image``, at the detector's scale) with the
        spots on the chroma of ``axis`` (3,) floored at the frame's ``floor`` [DN] in the box of
        ``found`` grown by ``DIM_REACH`` diameters, farther than a diameter from all of
        ``found`` (``DetectorConfig.dim_spots``)."""
        s = self.config.downscale
        diameter = max(self.config.marker_diameter_px, self.config.min_separation_px)
        h, w = image.shape[:2]
        lo = np.floor((found.uv.min(axis=0) - DIM_REACH * diameter + 0.5) / s - 0.5)
        hi = np.ceil((found.uv.max(axis=0) + DIM_REACH * diameter + 0.5) / s - 0.5)
        x0, y0 = max(int(lo[0]), 0), max(int(lo[1]), 0)
        x1, y1 = min(int(hi[0]) + 1, w), min(int(hi[1]) + 1, h)
        if x1 - x0 < 3 or y1 - y0 < 3:
            return found
        shift = np.array([x0 * s, y0 * s], np.float64)  # the box's corner [full-size px]
        dim = self._spots(np.ascontiguousarray(image[y0:y1, x0:x1]), floor, axis,
                          frame_floor=floor, dark_bar=clay_bar(image, axis),
                          away=(found.uv - shift, diameter))
        if not len(dim.uv):
            return found

        def joined(mine: NDArray[Any] | None, added: NDArray[Any] | None,
                   default: NDArray[Any], extra: NDArray[Any]) -> NDArray[Any]:
            return np.concatenate([default if mine is None else mine,
                                   extra if added is None else added])

        centre = None if found.centre is None and dim.centre is None else joined(
            found.centre, None if dim.centre is None else dim.centre + shift, found.uv,
            dim.uv + shift)
        return found._replace(
            uv=np.concatenate([found.uv, dim.uv + shift]),
            confidence=np.concatenate([found.confidence, dim.confidence]),
            size_px=np.concatenate([found.size_px, dim.size_px]), centre=centre,
            mass=None if found.mass is None or dim.mass is None else np.concatenate(
                [found.mass, dim.mass]),
            crowded=None if found.crowded is None else joined(
                found.crowded, dim.crowded, found.crowded, np.zeros(len(dim.uv), np.bool_)),
            parted=None if found.parted is None else joined(
                found.parted, dim.parted, found.parted, np.zeros(len(dim.uv), np.bool_)),
            flux_shift=None if found.flux_shift is None and dim.flux_shift is None else joined(
                found.flux_shift, dim.flux_shift, np.zeros((len(found.uv), 2)),
                np.zeros((len(dim.uv), 2))))

    def _patch(self, image: NDArray[np.uint8], axis: NDArray[np.float32], point: FloatArray,
               half_px: float) -> tuple[NDArray[np.float32], tuple[int, int]]:
        """(h, w) the chroma of ``image`` (at the detector's scale) on ``axis`` (3,), floored
        at ``MIN_SUM_DN`` as the spots were measured, around ``point`` (2,) [full-size px]
        within ``half_px`` [full-size px], and its corner (x0, y0) [detector px] (``Detections.
        patch``)."""
        s = self.config.downscale
        q = (np.asarray(point, np.float64) + 0.5) / s - 0.5
        reach = int(np.ceil(half_px / s))
        h, w = image.shape[:2]
        x0, y0 = max(int(q[0]) - reach, 0), max(int(q[1]) - reach, 0)
        x1, y1 = min(int(q[0]) + reach + 2, w), min(int(q[1]) + reach + 2, h)
        if x1 <= x0 or y1 <= y0:
            return np.zeros((0, 0), np.float32), (x0, y0)
        return chroma(np.ascontiguousarray(image[y0:y1, x0:x1]), MIN_SUM_DN, axis), (x0, y0)

    def _spots(self, image: NDArray[np.uint8], floor: float,
               axis: NDArray[np.float32], thr: float | None = None,
               frame_floor: float = MIN_SUM_DN, dark_bar: float = 0.0,
               away: tuple[FloatArray, float] | None = None) -> Detections:
        """The markers of ``image`` (at the detector's scale) on the chroma of ``axis`` (3,)
        floored at ``floor`` [DN], without the faint search; ``thr``: the threshold (None:
        ``threshold``); ``dark_bar`` [DN]: the least
        5 x 5 mean ``B + G + R`` of a spot (:func:`~dempath_recon.tracking.colour_model.
        clay_bar`; 0: none); ``frame_floor``: the
        frame's own floor [DN] (``chroma_floor``), on which a dim frame's published centres
        are measured (``shade_centres``); ``away``: spots (n, 2) [full-size px, in ``image``]
        and a distance [full-size px]: only peaks farther than that from all of them are
        kept, each as one marker (no splitting: the dim pass, ``_dim_spots``)."""
        s = self.config.downscale
        thr = self.config.threshold if thr is None else thr
        # the band-pass in frames in normal light only: in a dim one the fixed floor divides
        # sand and markers alike by a constant, not their own light, and its contrast bar does
        # not hold (there the dim pass is the rule); the dim pass keeps its own tuned rule
        band = self._band if away is None and frame_floor >= MIN_SUM_DN else 0
        ox, oy, c, parts = self._window(image, thr, floor, axis)
        rows, cols, fixed = self._peaks(c, thr, band)
        lit = lit_peaks(image, rows + oy, cols + ox, floor)  # not noise in near-black pixels
        lit &= bright_peaks(image, rows + oy, cols + ox, dark_bar)
        rows, cols, fixed = rows[lit], cols[lit], fixed[lit]
        if not fixed.all():  # the band-pass's own spots: whole enough markers only
            rows, cols = self._seen_enough(c, rows, cols, fixed, band)
        if away is not None and len(away[0]) and len(rows):
            at = (np.stack([cols + ox, rows + oy], axis=1) + 0.5) * s - 0.5
            far = np.linalg.norm(at[:, None] - away[0][None], axis=2).min(axis=1) > away[1]
            rows, cols = rows[far], cols[far]
        if len(rows) == 0:
            return Detections.empty()
        uv, size, strength, mass = self._refine(c, rows, cols, thr)
        own_mass = mass
        centre, parted, flux_shift = None, None, None
        diameter = self.marker_size(size * s)
        if diameter > 0:
            radius = 0.5 * diameter / s
            base = 0.5 * self.config.threshold
            if away is None:
                uv, source, parted, disc = split_touching(c, uv, base, radius, self._cut_up,
                                                          self.config.split_wide,
                                                          self.config.split_gain)
            else:  # the dim pass: each spot one marker
                source, parted, disc = np.arange(len(uv)), np.zeros(len(uv), np.bool_), uv.copy()
            # a fitted marker's size is one disc's radius of gyration, not its blob's
            size = np.where(parted, radius / np.sqrt(2.0), size[source])
            strength, mass = strength[source], mass[source]
            own_mass = mass / np.bincount(source, minlength=int(source.max()) + 1)[source] \
                if len(source) else mass  # a split blob's markers share its mass
            seen_uv, dim_floor = uv, shade_floor(frame_floor, floor) \
                if self.config.shade_centres else None
            # another clay's seen share from its mass alone: on its axis a spot's peak pixel
            # is noise (white reads -0.55 on red clay's axis, 0 on blue's; the sand's chroma
            # noise is 3-4 times blue's, track30), so dividing by it read whole red markers as
            # covered and moved 36-43 % of them down (blue 20-27 %; session 22)
            peaky = is_blue(axis)
            if dim_floor is not None:  # a dim frame: published centres on the own light
                own = parts.floored(dim_floor)  # the window's chroma at the frame's floor
                seen_uv, lit_peak, lit_mass = lit_centroids(own, uv, self._refine, thr)
                share = seen_share(np.where(np.isfinite(lit_mass), lit_mass, mass),
                                   np.where(np.isfinite(lit_peak), lit_peak, strength) - base
                                   if peaky else None)
            else:
                share = seen_share(mass, strength - base if peaky else None)
                if self.config.smooth_centres:
                    seen_uv = self._smooth_centroids(c, uv, parted, thr)
            if tuple(self.config.up_px) != (0.0, 0.0):
                centre = disc if share is None else uncover(
                    seen_uv, share, radius, self.config.up_px, ~parted,
                    self.config.view_elevation_deg)[0]
                if self.config.flux_share:
                    flux = seen_share(spot_flux(c, uv, radius), None)
                    flux_shift = np.zeros_like(uv) if flux is None else np.where(
                        parted[:, None], 0.0, uncover(seen_uv, flux, radius, self.config.up_px,
                                                      ~parted, self.config.view_elevation_deg,
                                                      )[0] - centre)
                centre = np.where(parted[:, None], disc, centre) + np.array([ox, oy], np.float64)
            elif dim_floor is not None or self.config.smooth_centres:
                centre = np.where(parted[:, None], uv, seen_uv) + np.array([ox, oy], np.float64)
        uv += (ox, oy)
        ok = np.isfinite(uv).all(axis=1)
        conf = np.clip((strength - thr) / (2 * thr), 0, 1)
        full = (uv[ok] + 0.5) * s - 0.5  # half-size pixel centre i -> full-size 2i + 0.5
        size = size[ok] * s
        crowded = size > CROWDED_SIZE * diameter if diameter > 0 else None
        if centre is not None:
            centre = (centre[ok] + 0.5) * s - 0.5
        return Detections(full, conf[ok], size, crowded, None, centre,
                          None if parted is None else parted[ok], mass=own_mass[ok] * s * s,
                          flux_shift=None if flux_shift is None else flux_shift[ok] * s)

    def _smooth_centroids(self, c: NDArray[np.float32], uv: FloatArray,
                          parted: NDArray[np.bool_], thr: float) -> FloatArray:
        """(n, 2) each spot's centre [detector px, window ``c``] as the iterated centroid of
        the chroma ``c`` smoothed by a Gaussian of ``CENTRE_SMOOTH`` times the matched filter's
        (from the spot's centre ``uv`` (n, 2)); ``uv`` for a fitted marker of a split blob
        (``parted`` (n,)) and where the centroid is not found.

        Why: the weighted centroid sums each pixel's chroma noise with its offset as weight; a
        light Gaussian first (part of the matched filter) averages that noise over neighbours
        and leaves a symmetric spot's centre where it was. Only the published centres take it
        (the trackers' margins were tuned on ``uv``)."""
        out = np.asarray(uv, np.float64).copy()
        ok = np.isfinite(out).all(axis=1) & ~np.asarray(parted, np.bool_)
        if not ok.any():
            return out
        smooth = np.asarray(cv2.GaussianBlur(c, (0, 0), CENTRE_SMOOTH * self._sigma), np.float32)
        h, w = c.shape
        rows = np.clip(np.rint(out[ok, 1]), 0, h - 1).astype(np.intp)
        cols = np.clip(np.rint(out[ok, 0]), 0, w - 1).astype(np.intp)
        centred = self._refine(smooth, rows, cols, thr)[0]
        out[ok] = np.where(np.isfinite(centred), centred, out[ok])
        return out

    def _seen_enough(self, c: NDArray[np.float32], rows: NDArray[np.intp],
                     cols: NDArray[np.intp], fixed: NDArray[np.bool_], band: int,
                     ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """The peaks (``rows``, ``cols`` (n,) in the chroma window ``c``) the fixed rule
        passes (``fixed`` (n,)) and those of the band-pass (background square ``band``
        [detector px]) whose excess chroma says enough of a marker is seen
        (:func:`~dempath_recon.tracking.band_pass.kept_spots`); without a marker size, the
        fixed rule's only."""
        diameter = self.config.marker_diameter_px / self.config.downscale
        if diameter <= 0:
            return rows[fixed], cols[fixed]
        part = np.maximum(c, np.float32(FILTER_FLOOR)) if self.config.floor_sand else c
        keep = kept_spots(fixed, excess_mass(part, rows, cols, band, MASS_REACH * diameter))
        return rows[keep], cols[keep]

    def _peaks(self, c: NDArray[np.float32], thr: float, band: int = 0,
               ) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.bool_]]:
        """(rows, cols) of the matched filter's local maxima among the pixels above ``thr``,
        over half ``thr`` (at most ``max_markers``, the strongest), and (n,) all True; with
        ``band`` (the side of the background square [detector px], ``DetectorConfig.
        band_pass``): the local maxima of the filter less the local background over
        ``band_pass.BAND_THRESHOLD`` and whether the filter alone passes half ``thr`` there."""
        empty = np.zeros(0, np.intp)
        cand = cv2.findNonZero((c > thr).view(np.uint8)) if c.size else None
        if cand is None:
            return empty, empty, np.zeros(0, np.bool_)
        # filter only around the candidate pixels (the markers cover a small part of the view),
        # each cluster of them apart (another clay's dark corners lie far from the markers);
        # the margin makes the result identical to filtering the whole image
        pad = int(np.ceil(4 * self._sigma)) + self._kernel.shape[0] // 2 + 2 + band // 2
        cols, rows = np.asarray(cand[:, 0, 0], np.intp), np.asarray(cand[:, 0, 1], np.intp)
        peak = np.zeros(len(cand), np.bool_)
        local = np.zeros(len(cand), np.float32)
        alone = np.zeros(len(cand), np.float32)  # the filter alone (no background taken)
        groups = candidate_groups(rows, cols, PEAK_TILE)
        if len(groups) > MAX_PEAK_GROUPS:  # noise spread over the view: one box is cheaper
            groups = [np.arange(len(rows))]
        for group in groups:
            r, q = rows[group], cols[group]
            x0, y0 = max(int(q.min()) - pad, 0), max(int(r.min()) - pad, 0)
            x1, y1 = min(int(q.max()) + 1 + pad, c.shape[1]), min(int(r.max()) + 1 + pad,
                                                                   c.shape[0])
            part = c[y0:y1, x0:x1]
            if self.config.floor_sand:
                part = np.maximum(part, np.float32(FILTER_FLOOR))
            smooth = cv2.GaussianBlur(part, (0, 0), self._sigma)
            if band:  # less the local background (Crocker and Grier's band-pass)
                alone[group] = smooth[r - y0, q - x0]
                smooth = cv2.subtract(smooth, local_background(part, band))
            local[group] = smooth[r - y0, q - x0]
            peak[group] = local[group] >= neighbourhood_max(smooth, r - y0, q - x0, self._reach)
        if band:
            fixed = alone > 0.5 * thr
            passed = local > BAND_THRESHOLD
            peak &= passed | fixed if self.config.band_adds_only else passed
        else:
            fixed = np.ones(len(cand), np.bool_)
            peak &= local > 0.5 * thr
        rows, cols, strength, fixed = rows[peak], cols[peak], local[peak], fixed[peak]
        if len(rows) > self.config.max_markers:
            keep = np.argsort(-strength)[:self.config.max_markers]
            rows, cols, fixed = rows[keep], cols[keep], fixed[keep]
        return rows.astype(np.intp), cols.astype(np.intp), fixed

    def _faint(self, image: NDArray[np.uint8], low: float,
               colour: tuple[float, NDArray[np.float32]], strong: FloatArray,
               points: FloatArray, radius_px: float,
               steps: FloatArray | None = None, *,
               whole: Callable[[], float] | None = None) -> FloatArray:
        """(k, 2) full-size centre of the strongest spot above ``low`` (the chroma of the
        frame's ``colour``: its floor [DN] and axis (3,)) (or of the streak along
        ``steps`` (k, 2) [full-size px] where one is at least ``STREAK_MIN_PX`` long) within
        ``radius_px`` of each point (k, 2) [full-size px], NaN where none or where it is the
        frame's own spot (within ``min_separation_px`` of one of ``strong`` (n, 2): a marker's
        rim). The window's own noise bar is tried where the window's median ``B + G + R`` is
        under ``MIN_SUM_DN`` (``local_bar``)."""
        s = self.config.downscale
        floor, axis = colour
        pts = np.asarray(points, np.float64).reshape(-1, 2)
        out = np.full((len(pts), 2), np.nan)
        moves = np.zeros_like(pts) if steps is None else np.asarray(steps, np.float64)
        reach = radius_px / s
        grow = int(np.ceil(reach + 4 * self._sigma)) + self._offsets[0].shape[0] + 2
        h, w = image.shape[:2]
        for k, p in enumerate(pts):
            q = (p + 0.5) / s - 0.5
            streak = bool(np.hypot(*moves[k]) >= STREAK_MIN_PX)
            more = int(np.ceil(0.5 * np.abs(moves[k]).max() / s)) if streak else 0
            if not np.isfinite(q).all():
                continue
            x0, y0 = max(int(q[0]) - grow - more, 0), max(int(q[1]) - grow - more, 0)
            x1, y1 = min(int(q[0]) + grow + more + 1, w), min(int(q[1]) + grow + more + 1, h)
            if x1 - x0 < 3 or y1 - y0 < 3:
                continue
            window = np.ascontiguousarray(image[y0:y1, x0:x1])
            corner = np.array([x0, y0], np.float64)
            c = chroma(window, floor, axis) if not streak else None
            if c is not None:
                out[k] = self._faint_spot(c, (x0, y0), q, reach, low, strong)
            if streak or (self.config.local_bar and not np.isfinite(out[k]).all()
                          and dim(window)):
                c = chroma(window, DARK_SUM_DN, axis)
                if self.config.floor_sand:
                    c = np.maximum(c, np.float32(FILTER_FLOOR))
                out[k] = self._own(corner + find_streak(c, q - corner, moves[k] / s, self._sigma,
                                                        reach, self._radius), strong)
            elif (c is not None and whole is not None and self._contrast
                  and not np.isfinite(out[k]).all()
                  and self._isolated(p, strong, ISOLATION * self._diameter * s - radius_px)):
                out[k] = self._own(corner + contrast_spot(
                    np.maximum(c, np.float32(FILTER_FLOOR)), q - corner,
                    (strong + 0.5) / s - 0.5 - corner, whole, sigma=self._sigma, reach=reach,
                    radius=self._radius, diameter=self._diameter), strong)
        return out

    @staticmethod
    def _isolated(point: FloatArray, strong: FloatArray, distance: float) -> bool:
        """Whether ``point`` (2,) [full-size px] lies farther than ``distance`` [full-size px]
        from every one of the frame's spots ``strong`` (n, 2) [px] (a contrast spot within
        the gate of it could lie farther than ``ISOLATION`` diameters from them all)."""
        return not len(strong) or bool(np.hypot(*(strong - point).T).min() > distance)

    def _whole_excess(self, image: NDArray[np.uint8], axis: NDArray[np.float32],
                      strong: FloatArray) -> float:
        """A whole marker's excess chroma in ``image`` (at the detector's scale) on ``axis``
        (3,): :func:`~dempath_recon.tracking.contrast_faint.whole_excess` of the frame's spots
        ``strong`` (n, 2) [full-size px], measured on the chroma (floored at ``MIN_SUM_DN``
        and the sand, as the faint spot's) of the box around them all, in one call."""
        s = self.config.downscale
        pts = np.rint((np.asarray(strong, np.float64).reshape(-1, 2) + 0.5) / s - 0.5)
        h, w = image.shape[:2]
        pts = pts[(pts[:, 0] >= 0) & (pts[:, 0] < w) & (pts[:, 1] >= 0) & (pts[:, 1] < h)]
        if not len(pts):
            return float('nan')
        half = self._band // 2 + int(np.ceil(MASS_REACH * self._diameter)) + 2
        x0, y0 = max(int(pts[:, 0].min()) - half, 0), max(int(pts[:, 1].min()) - half, 0)
        x1, y1 = min(int(pts[:, 0].max()) + half + 1, w), min(int(pts[:, 1].max()) + half + 1, h)
        part = np.maximum(chroma(np.ascontiguousarray(image[y0:y1, x0:x1]), MIN_SUM_DN, axis),
                          np.float32(FILTER_FLOOR))
        cells = pts.astype(np.intp) - np.array([x0, y0], np.intp)
        return whole_excess(excess_mass(part, cells[:, 1], cells[:, 0], self._band,
                                        MASS_REACH * self._diameter))

    def _faint_spot(self, c: NDArray[np.float32], corner: tuple[int, int], q: FloatArray,
                    reach: float, low: float, strong: FloatArray) -> FloatArray:
        """(2,) full-size centre of the strongest spot above ``low`` in the chroma window ``c``
        (its corner at ``corner`` [detector px]) within ``reach`` of ``q`` (2,) [detector px],
        NaN where none or where it is one of the frame's spots ``strong`` (n, 2) [px]."""
        s = self.config.downscale
        x0, y0 = corner
        rows, cols, _ = self._peaks(c, low)
        near = np.hypot(cols + x0 - q[0], rows + y0 - q[1]) <= reach
        rows, cols = rows[near], cols[near]
        if not len(rows):
            return np.full(2, np.nan)
        uv, _, peak, _ = self._refine(c, rows, cols, low)
        spots = (uv + (x0, y0) + 0.5) * s - 0.5
        ok = self._apart(spots, strong)
        if not ok.any():
            return np.full(2, np.nan)
        return np.asarray(spots[ok][int(np.argmax(peak[ok]))], np.float64)

    def _own(self, q: FloatArray, strong: FloatArray) -> FloatArray:
        """(2,) full-size position of a spot at ``q`` (2,) [detector px], NaN if not found or
        within ``min_separation_px`` of one of the frame's spots ``strong`` (n, 2) [px]."""
        s = self.config.downscale
        p = np.asarray((q + 0.5) * s - 0.5, np.float64).reshape(1, 2)
        return p[0] if self._apart(p, strong)[0] else np.full(2, np.nan)

    def _apart(self, spots: FloatArray, strong: FloatArray) -> NDArray[np.bool_]:
        """(m,) whether each full-size spot (m, 2) [px] is finite and farther than
        ``min_separation_px`` from every one of the frame's spots ``strong`` (n, 2) [px] (not
        that spot's rim)."""
        ok = np.asarray(np.isfinite(spots).all(axis=1), np.bool_)
        if len(strong) and len(spots):
            ok &= np.linalg.norm(spots[:, None] - strong[None], axis=2).min(axis=1) \
                > self.config.min_separation_px
        return ok

    def marker_size(self, size_px: FloatArray) -> float:
        """A marker's diameter in this frame [full-size px]: ``marker_diameter_px``, or more
        when the frame's spots say its markers are larger (the median spot's radius of
        gyration over ``TYPICAL_SIZE``, from ``MIN_SPOTS`` spots on): markers bigger than the
        configured size would otherwise all look like touching pairs. 0: no splitting."""
        wanted = self.config.marker_diameter_px
        if wanted <= 0 or len(size_px) < MIN_SPOTS:
            return wanted
        return max(wanted, float(np.median(size_px)) / TYPICAL_SIZE)

    def _window(self, image: NDArray[np.uint8], thr: float, floor: float = MIN_SUM_DN,
                axis: NDArray[np.float32] | None = None,
                ) -> tuple[int, int, NDArray[np.float32], ChromaParts]:
        """The chroma of the part of ``image`` that can hold markers: ``(x0, y0, chroma,
        parts)``, ``parts`` its numerator and ``B + G + R`` (:class:`~dempath_recon.tracking.
        colour_model.ChromaParts`: the same window at another floor without a second pass).

        A pixel's chroma exceeds the threshold only where ``B - R > threshold * floor``
        (the chroma's denominator is at least the frame's ``floor`` [DN]), which a saturating
        byte subtraction and a threshold find at a fraction of the chroma's cost (another
        clay's axis: its weighted sum, :func:`~dempath_recon.tracking.colour_model.
        axis_bound`). The window is the bounding box of those pixels grown by the reach of
        the filter, the local-maximum search and the centroid window (``_pad``): it holds
        every pixel above the threshold and all that is read around them, so the detections
        equal those of the whole frame (tested).
        A box over ``SPARSE_BOX`` of the frame is first narrowed to the pixels whose chroma
        passes (``_exact_box``); a frame whose passing pixels spread over most of the view is
        done whole.
        """
        h, w = image.shape[:2]
        above: NDArray[np.generic]
        level = max(int(np.floor(thr * floor)) - 1, 0)
        pixels, num = None, None
        if axis is None or is_blue(axis):
            blue = cv2.subtract(cv2.extractChannel(image, 0), cv2.extractChannel(image, 2))
            above = cv2.threshold(blue, level, 255, cv2.THRESH_TOZERO)[1]
        else:  # the numerator, computed once for the bound and the window's chroma
            pixels = image.astype(np.float32)
            num = axis_numerator(pixels, axis)
            above = axis_bound(num, level)
        x, y, bw, bh = cv2.boundingRect(above)
        if bw * bh > SPARSE_BOX * h * w:
            # stray pixels far apart spread the box
            x, y, bw, bh = self._exact_box(image, above, thr, floor, axis)
        if bw == 0 or bh == 0:
            empty = np.zeros((0, 0), np.float32)
            return 0, 0, empty, ChromaParts(empty, empty)
        pad = self._pad
        x0, y0 = max(x - pad, 0), max(y - pad, 0)
        x1, y1 = min(x + bw + pad, w), min(y + bh + pad, h)
        if (x1 - x0) * (y1 - y0) > 0.5 * h * w:
            x0, y0, x1, y1 = 0, 0, w, h
        if pixels is None or num is None or axis is None:
            parts = blue_parts(np.ascontiguousarray(image[y0:y1, x0:x1]))
        else:  # per pixel: the window's numerator is the frame's, cut (tested)
            parts = axis_parts(np.ascontiguousarray(pixels[y0:y1, x0:x1]), axis,
                               np.ascontiguousarray(num[y0:y1, x0:x1]))
        return x0, y0, parts.floored(floor), parts

    @staticmethod
    def _exact_box(image: NDArray[np.uint8], above: NDArray[Any], thr: float, floor: float,
                   axis: NDArray[np.float32] | None) -> tuple[int, int, int, int]:
        """The bounding box ``(x, y, w, h)`` of the pixels whose chroma exceeds ``thr``, from
        the chroma of the pixels the byte bound ``above`` keeps (the chroma is per pixel, so
        this equals the whole frame's; (0, 0, 0, 0): none).

        The byte bound passes every pixel whose colour axis exceeds ``thr`` times the floor,
        bright or not; on a grey bed, or with red clay beside a brown ground beyond the bin,
        a few dozen such pixels lie across the whole view (session 19: 225 pixels in 31 of
        1296 20-px tiles of a side view, red clay on grey sand), the box became the frame and
        the chroma, the filter and the splitting ran over all of it (8 ms of 14 ms a frame).
        """
        pts = cv2.findNonZero(above)
        if pts is None:
            return 0, 0, 0, 0
        xs, ys = pts[:, 0, 0], pts[:, 0, 1]
        passed = chroma(np.ascontiguousarray(image[ys, xs][None]), floor, axis)[0] > thr
        if not passed.any():
            return 0, 0, 0, 0
        x, y, w, h = cv2.boundingRect(pts[passed])
        return x, y, w, h

    def _refine(self, c: NDArray[np.float32], rows: NDArray[np.intp], cols: NDArray[np.intp],
                thr: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Iterated weighted centroids around each peak: uv (n, 2), size (n,), peak (n,) and
        mass (n,): the chroma above the core level summed over the final window
        (:func:`~dempath_recon.tracking.centroid_kernel.refine_centroids`, at most 6 steps,
        until a step is under 0.01 px)."""
        base = 0.5 * self.config.threshold  # the spot's core, whatever found it
        out = np.full((len(rows), 2), np.nan)
        size, mass = np.zeros(len(rows)), np.zeros(len(rows))
        peak = c[rows, cols].astype(np.float64)
        refine_centroids(np.ascontiguousarray(c, np.float32), np.asarray(rows, np.intp),
                         np.asarray(cols, np.intp), float(self._radius),
                         self._offsets[0].shape[0] // 2, base, 6, 0.01, out, size, mass)
        return out, size, peak, mass
