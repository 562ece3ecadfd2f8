"""The records of the two-camera marker tracker: its settings, one camera frame's numbered
pixels, and the counts of what happened to each camera's frames (the run report's rows).

Kept apart from the tracker (:mod:`dempath_recon.tracking.stereo` re-exports them), so that
the records stand below everything that uses them, ``trajectories`` included.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import DetectorConfig
from dempath_recon.tracking.linker import TrackerConfig

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class StereoTrackConfig:
    """Settings of the two-camera marker pipeline.

    Attributes:
        detector: detector settings.
        tracker: linker settings.
        grid: the initial marker grid.
        fps: nominal frame rate [1/s] (dropped frames are gaps above 1.5 periods).
        epipolar_px: largest distance to the epipolar line for numbering a new track [px]; a
            numbered pair farther than 3 times this from it is withheld.
        min_grid_markers: detections that must fit the projected grid before a camera's
            markers are numbered by it (frames with fewer wait for a later frame).
        grid_gate_px: largest distance of a detection from its fitted grid point [px]; a
            marker this camera has never seen that appears alone within it later (covered at
            the start) takes that grid point's number.
        position_gate_m: 3D allowance of a numbered pair around the marker's last accepted
            position, for noise, the cameras' exposure offset and the marker's size [m].
        doubt_link_px: a track that fails a check against the other camera loses its number
            when one of its links since its last passed check missed the prediction by more
            than this [px] (markers moving smoothly miss by a pixel or two).
        max_speed_m_s: fastest a marker can move [m/s] (the tool's speed, 1 m/s in the
            paper, with a margin: sand ahead of the tool does not outrun it by much).
        tool_speed_m_s: the tool's speed as the user knows it [m/s]; it bounds each camera's
            frame-to-frame links (:mod:`~dempath_recon.tracking.speed_bound`, unless
            ``tracker.max_image_speed_px_s`` is set). 0: not known, no bound.
        number_delay_frames: frames of its camera a frame is held in
            ``StereoMarkerTracker.release`` before it is given out; a point of a then
            unnumbered track goes out with the number the track got within the delay (a
            marker that comes back is often numbered a few frames later, when the other
            camera sees it too). 0 gives every frame out as it is numbered on arrival (what
            ``update`` returns, whatever this is).
        marker_diameter_m: the markers' diameter [m] (the paper's clay spheres: about 8 mm);
            with the calibration and the grid's depth it gives each camera's detector the
            expected size of a marker in the image, by which touching markers are split
            (``DetectorConfig.marker_diameter_px``, unless that is set). 0: no splitting.
        shake: estimate each camera's image motion per frame from the parts of the view that
            do not move and move the detections back by it (``shake``) before anything else
            uses them; off: the detections are taken where they are seen.
        shake_reference: place the shake against the view of the frames the calibration was
            made on, when given (``StereoMarkerTracker.add_reference``), rather than take its
            mean over the pass as zero: a pass seen off the calibration as a whole (a camera
            knocked, or a few frames' shake that does not average out) is corrected too.
        shake_shrink: with ``whole_pass``, once the pass is numbered, scale each frame's
            shake about the pass's mean by the share of the shifts' scatter that is not the
            estimate's own noise (a Wiener gain,
            :meth:`~dempath_recon.tracking.shake.ShakeEstimator.placed`): a camera that does
            not shake is not moved by the estimate's noise; the numbers stay those decided on
            the shake as estimated.
        shake_align: register each frame twice, its tiles cut again where the reference's
            content went (whole pixels of the registered image) after the first: the fixed
            window pulls the estimate toward zero by about 6 % of the shift
            (:meth:`~dempath_recon.tracking.shake.ShakeEstimator.update`).
        uncover: give each camera's detector the image direction of world up from the
            calibration (``DetectorConfig.up_px``, unless that is set), so a partly covered
            marker's centre is its disc's, not the middle of its visible part
            (:mod:`~dempath_recon.tracking.covered`). False: centroids as found.
        publish_gate: withhold, as frames are given out, a numbered point whose pair's 3D
            point jumps away from where the marker's neighbours' motion puts it
            (:mod:`~dempath_recon.tracking.publish_gate`).
        elimination: number a track only one camera sees, left unnumbered at the grid fit,
            by the grid point it started nearest among the markers nobody holds
            (:mod:`~dempath_recon.tracking.grid_elimination`).
        record_numbers: keep a record of every number a track is given or has taken back,
            with the rule, the frame and the evidence (``StereoMarkerTracker.record``,
            :mod:`~dempath_recon.tracking.number_record`). Off by
            default: it grows with the recording (for benches and tracing, not live nodes).
        coming_out: number a new track only one camera sees, born after the grid fit, by the
            marker the bed has carried nearest it (a marker coming out of the sand mid-pass:
            :mod:`~dempath_recon.tracking.coming_out`).
            Off by default: together with ``numbered_partner`` it numbered the 23 tuning looks
            78.94 -> 79.40 % right (switches 26, wrong pairs 1, unchanged), 14 seed-87 looks
            more or the same, but six seed-89 looks held apart went 92.66 -> 92.24 % (session
            19, track23); the loss is this rule's alone (``s89_grey_glare`` 98.33 -> 94.44 %:
            it numbers one camera's spot of a marker both cameras then found, which the pair
            numbering would have numbered in both; session 20, track25).
        numbered_partner: when ``track_pairs``' carried-point test refuses a partner the other
            camera numbers, name it again with only the markers the other camera does not see
            as rivals and a 30 mm gate, if no other track of the other camera lies on the line
            at a nearer pair (``track_pairs._numbered_name``). On since session 20 (track25):
            it never added a switch or a wrong-pair point on any set scored (10 long tuning
            looks 84.80 -> 85.25 % numbered right, 23 tiny tuning looks 78.99 -> 79.06, 14
            seed-87 looks 83.22 -> 83.76, six seed-89 looks 92.66 -> 92.90).
        regain: give a number elimination took back for a jump (a link off its prediction, no
            re-attachment) back to the track and its partner once the other camera's track
            held on its epipolar line where the bed carried the marker
            (:mod:`~dempath_recon.tracking.regain`; with ``elimination``).
        crowded_pairs: hold a pair whose partner was seen at the same instant to
            ``epipolar_px``, and when it fails there take the number back from the track of
            either camera whose spot is crowded by another track
            (:mod:`~dempath_recon.tracking.crowded_pair`: a neighbour that slid over or came
            out where the marker sank). False: such pairs get three times ``epipolar_px``.
        crowd_give_back: give such a number back once the track is on its own marker again
            (:func:`~dempath_recon.tracking.crowded_pair.give_back`; with ``crowded_pairs``).
        half_ghost: at the grid fit, leave unnumbered a pair's spot that lies nearer the
            image grid point of a marker no pair claims, in its camera alone (the front of two
            markers on one line of sight, the other camera seeing only the one behind:
            :mod:`~dempath_recon.tracking.half_ghost`); its partner keeps the number.
        merge_release: take a track's number back where a neighbour's blob merged into its
            spot in this camera (a track left unlinked beside it, the spot grown:
            :mod:`~dempath_recon.tracking.merge_release`).
        track_split: before linking, split a spot that two or three numbered tracks of the
            camera predict, by a fit of that many discs started at their predictions, where
            each fitted centre lies on its number's epipolar line in the other camera
            (:mod:`~dempath_recon.tracking.track_split`). Off by default (session 22,
            track37): the released tuning set heldout21 numbers 2.2 points more with a switch
            fewer, but on the 23 tiny tuning looks switches rose 25 -> 35 and wrong pairs
            1 -> 7 (``r21_dusk``: after a right split ``track_pairs`` paired two other
            markers wrongly), and a long look lost 1.6 points with a switch more.
        line_rival: elimination leaves a track to the pair rules for a spot of the other
            camera on its epipolar line only when their pair lies near where the bed carried
            a marker that spot may be (an unnumbered spot: a marker nobody holds; a marker the
            other camera gives out: that one) (:mod:`~dempath_recon.tracking.line_rival`: an
            epipolar line crosses the bed, and the spot on it is often another marker; long
            tuning looks 85.47 -> 86.25 % numbered right, no switch or wrong pair added);
            False: any such spot defers it.
        whole_pass: hold every frame till ``StereoMarkerTracker.flush`` (the end of the pass:
            each frame is numbered when due, ``number_delay_frames`` after it came), then
            number the tracks no rule numbered from all the pass's frames at once, by one
            optimal assignment with a refusal margin (:mod:`~dempath_recon.tracking.
            whole_pass`: a track that stays on one marker's epipolar line over the pass while
            every rival strays is that marker). The lossless detector nodes then publish
            at the end of the recording; live nodes (``update``'s frames) are not affected.
            On since session 22 (track35; main 8f5be33): numbered right 79.88 -> 81.56 % on
            heldout21's eight looks, 88.13 -> 88.44 on the ten long tuning looks, 80.56 ->
            81.09 on the 23 tiny ones, 86.47 -> 86.99 on six seed-169 looks, six held-apart
            seed-171 looks unchanged; switches and wrong-pair points unchanged on each
            (docs/reconstruction.md). False: frames go out when due.
        joint_fill: with ``whole_pass``, after its numbering, number the spots still
            unnumbered from each marker's 3D path over the pass (its numbered pairs), by one
            assignment per instant over both cameras' spots with a refusal margin
            (:mod:`~dempath_recon.tracking.joint_fill`). On since session 23 (track39): nine
            tiny tuning looks (seeds 201/203/205) 90.07 -> 92.49 % numbered right, four
            held-apart seed-207 looks 85.71 -> 86.13 %, the variation set's held-out pool
            a little more; no switch or wrong-pair point added on any (docs/figures.md).
            False: the whole pass's numbering alone.
        piece_numbering: with ``whole_pass``, after its numbering and before ``joint_fill``,
            number every unnumbered stretch of a 2D track (in either camera; paired in 3D
            where both cameras have one) by one assignment on how well it continues each
            marker's numbered path, with a refusal margin
            (:mod:`~dempath_recon.tracking.piece_numbering`). Off by default: on the lead's
            held-out set heldout26 (10 looks never seen by its author) it numbered 0.9 points
            more right but added 14 switches and 7 wrong-pair points (67 -> 81, 15 -> 22;
            docs/figures.md, session 24, the lead), and a wrong number is worse than none.
            Its author's figures (track42): 16 burnt tuning looks 86.91 -> 87.64 % numbered
            right (switches 29 -> 30, wrong-pair points 9 -> 9), six own tuning looks (seeds
            241/243/245) 85.00 -> 85.48 % (switches 43 -> 30, wrong pairs 21 -> 12); four held-
            apart seed-247 looks unchanged; the variation set's held-out pool 94.73 -> 95.19 %,
            0 switches and 0 wrong pairs kept (docs/figures.md). False: only tracks no frame
            numbered are numbered from the whole pass.
        bed_numbering: with ``whole_pass``, after ``piece_numbering`` and ``joint_fill``
            (before it without ``bed_after_fill``), number the unnumbered stretches of 2D
            tracks (in either camera; paired in 3D where both have one) by where the bed's
            motion carried each marker the cameras lack: its rest point (or own nearest
            numbered 3D point) moved as its numbered neighbours moved, Gaussian-weighted by
            their rest distance (or gaps, ``bed_sheared``), gated by the neighbours' spread,
            one assignment with a refusal margin in odds
            (:mod:`~dempath_recon.tracking.bed_numbering`). Off by default: safe but small
            and not cheap (session 25, number25: 41 tuning looks and 11 tuned variations
            91.19 -> 91.21 % numbered right, switches 174 and wrong-pair points 53 kept;
            held-apart seed 307 91.91 -> 92.06 %, 13 and 5 kept; about 0.9 ms of CPU a
            frame; docs/figures.md). False: no such step.
        bed_sheared: with ``bed_numbering``, the bed's field weighs a marker's neighbours by
            their rest gaps across the travel (sigma 0.35 grid pitch) and along it (2.0), not
            by their rest distance (1.0): the tool pushes its own column 50-140 mm and the
            next 5-60, the whole column alike (:mod:`~dempath_recon.tracking.bed_field`). On
            by default (session 26, alone26: with ``bed_after_fill`` the step numbers 79
            tuning looks 88.51 -> 88.73 % right, against 88.53 % without both, heldout27
            83.29 -> 84.22 % against 83.29; the held-apart seed as without both;
            docs/figures.md).
            False: the rest distance.
        bed_after_fill: with ``bed_numbering``, the step runs after ``joint_fill``, not
            before: a spot its marker's own 3D path fills is that marker's, and the field
            (a marker placed by its neighbours) numbers only what is left (the sheared field
            before the fill: on a tuning look a ghost pair of two pieces took a buried marker
            the field placed there before the fill gave each piece its own marker: 10
            switches). On by default. False: before.
        dim_spots: each camera's detector searches a dim frame's markers again on the chroma
            floored at the frame's own light (``DetectorConfig.dim_spots``; it must also be on
            there): at dusk the fixed floor divides a shaded or half-buried marker's chroma
            under the threshold. Off by default (session 23, track41): on 12 tuning looks
            numbered right 77.8 -> 80.9 % but identity switches 101 -> 121; the held-apart
            seed 88.5 -> 90.0 %, switches 3 -> 11 (docs/figures.md). False: the detectors'
            fixed floor only.
        band_pass: each camera's detector finds spots on the matched filter less the local
            background (``DetectorConfig.band_pass``, which this sets): markers on tinted or
            reddish sand and under a JPEG's blocky chroma pass where the fixed rule lost them.
            On by default (session 24, detect24: tuned variations 96.7 -> 97.6 % numbered
            right, the burnt tiny_long looks unchanged, 0 switches added; docs/figures.md).
            False: the fixed rule.
        smooth_centres: each camera's detector publishes centres measured on the chroma
            smoothed by a light Gaussian (``DetectorConfig.smooth_centres``, which this sets):
            less of JPEG's and the sensor's noise in the 3D points; detections and numbers
            unchanged (session 24, detect24: docs/figures.md). False: the raw chroma's.
        eager_split: each camera's detector splits a blob into touching markers where one
            more disc lowers the fit's squared residual ``split.EAGER_GAIN`` (1.7) times
            rather than ``split.GAIN`` (2) (``DetectorConfig.split_gain``, which this sets,
            unless the detector's settings give another): half the merged marker-frames of
            the burnt looks were pairs about a diameter apart whose two-disc fit was 1.6-2
            times better. Off by default (session 25, detect25: on 21 tuning looks numbered
            right 82.96 -> 83.89 %, switches 88 -> 63, wrong pairs 17 -> 10; on the seed held
            apart 86.79 -> 86.74 %, switches 43 -> 46: docs/figures.md). False:
            ``split.GAIN``.
        flux_share: with ``whole_pass``, a partly covered marker's published centre placed by
            the seen share its chroma flux over the local sand gives (``DetectorConfig.
            flux_share``, which this sets; :mod:`~dempath_recon.tracking.seen_flux`), not its
            centroid mass; only after every number and withholding is decided on the mass's
            centres, so numbers are unchanged. On by default (session 25, rms25: 3D RMS of
            the right pairs lower on 12 of 14 tuning looks, 3 of 3 low views of the held-apart
            seed; docs/figures.md). False: the centroid mass's centres.
        pass_audit: with ``whole_pass``, after its numbering, audit every number given
            (:mod:`~dempath_recon.tracking.pass_audit`): a piece of 2D track that carries two
            numbers keeps the one it carried longest, and a stretch of track its marker's
            lines in the other camera do not explain while another marker's 3D path (fitted
            robustly to both cameras' points) does is renumbered to that marker, or taken
            out where the camera gives that marker out. The frames' events say why. On since
            session 23 (audit3d): nine tuning looks (seeds 209/211/213) 67 -> 56 switches and
            26 -> 21 wrong-pair points, four held-apart seed-215 looks 20 -> 13 and 3 -> 2, no
            right number withheld, the variation set's held-out pool 0/0 unchanged
            (docs/figures.md). False: the numbers given out as numbered.
        audit_renumber: with ``pass_audit``, give an audited stretch the number the audit
            finds for it (its piece's longer number, or the marker whose 3D path explains a
            swap) instead of only withholding it. Off since session 26 (the lead): the
            marker found is one the stretch's camera does not give out there, so its path at
            those stamps stands on the other camera's points alone, its depth along that
            camera's ray extrapolated; the number given made pairs of two markers' spots, 3D
            points 30-80 mm from every marker (heldout27: 3 of its 4 ghost-pair runs). Off,
            on the 36 burnt looks of heldout24-27 (offline path, detections cached):
            200 -> 180 switches, 38 -> 28 wrong-pair points, numbered right 86.36 % both;
            the lead's decision looks (seeds 331-339, 6 looks): 38 -> 31, 14 -> 9, 3D RMS
            6.43 -> 1.73 mm, numbered right 85.21 % both. True: session 23-25's audit.
        carried_confirm: with ``whole_pass``, after the audit, withhold every number a 2D
            track carried over a break (a gap or a jump) onto a spot another marker was near
            that the other camera never confirms on the piece after the break
            (:mod:`~dempath_recon.tracking.carried_numbers`). Off by default (session 24,
            switch24): on the 16 burnt looks it was tuned on 29 -> 20 switches and 9 -> 6
            wrong-pair points for 86.97 -> 86.59 % numbered right, but on four renders made
            after it (seeds 271-277) and the held-apart seed 279 it took out no switch and
            cost 0.7 and 0.1 points (docs/figures.md). False: carried numbers given out.
        touch_confirm: with ``whole_pass``, then withhold both numbers of two markers that
            touched in one camera, on their tracks after the contact, unless the other camera
            tells the tracks apart there (:mod:`~dempath_recon.tracking.touching_exchange`).
            On since session 24 (switch24): four own renders (seeds 271-277) 25 -> 8 switches,
            9 -> 2 wrong-pair points, 3D RMS 2.45 -> 1.62 mm, 88.33 -> 88.21 % numbered right;
            16 burnt looks unchanged; held-apart seed 279 (five looks) 7 -> 7 switches, 2 -> 2
            wrong pairs, 95.27 -> 94.87 %; the variation set unchanged (docs/figures.md).
            False: the numbers given out as numbered.
        touch_wait: with ``touch_confirm``, judge a contact on every run of frames after it
            where the other camera gives a point of either marker, up to the pair's next
            contact, not only on the first frames after it: the numbers stay when any run tells
            the tracks apart (two markers that part along the other camera's epipolar line
            are told apart only once they are far enough apart, and the other camera may
            give neither for a while). On since session 25 (switch25): heldout26 (burnt, ten
            looks) 87.06 -> 87.91 % numbered right, its one-camera look S231_asis 88.5 ->
            95.9, switches and wrong pairs unchanged; nothing else changed on 29 more tuning
            looks, the held-apart seed 299 or the tuned variations (docs/figures.md). False:
            the first frames after it alone.
        touch_swap: with ``touch_confirm``, where the other camera tells the two tracks apart
            exchanged (the pairing as numbered off the epipolar lines by the same margin
            beyond the exchanged one), give each track the other's number from the contact
            on instead of withholding both. On since session 25 (switch25): S271_fast_dusk
            85.5 -> 89.5 % numbered right, 0 switches; nothing else changed on the tuning
            looks, the held-apart seed 299 or the tuned variations. False: withheld.
        smooth_paths: with ``whole_pass``, last, every numbered marker's image path in each
            camera smoothed by a Kalman (RTS) smoother whose amount the pass's own
            leave-one-out residuals choose, never across a gap or a jump
            (:mod:`~dempath_recon.tracking.path_smoother`); only centres move. On since
            session 24 (rms24): 21 tuning looks 3D RMS 1.910 -> 1.889 mm, the variation
            set's tuned pool 1.52 -> 1.43 and held-out pool 1.84 -> 1.61 mm, the held-apart
            seed 265 5.341 -> 5.335 mm (its wrong pairs); numbers, switches and wrong pairs
            unchanged or fewer on all (docs/figures.md); 0.3 ms of CPU a frame. False: the
            centres as detected.
        ray_rivals: at the grid fit, a spot one camera's image grid numbers alone (no pair)
            waits unnumbered while another marker no spot of its camera holds rests (its
            shifted grid point) within half a pitch of its line of sight, till the pass rules
            those out (:mod:`~dempath_recon.tracking.ray_rivals`). On since session 26
            (gridfit26: 36 burnt looks and four own renders, switches 258 -> 235, wrong-pair
            points 55 -> 55, numbered right 84.93 -> 84.83 %, no look with a switch added;
            the held-apart seed 367 and the tuned variations unchanged: docs/figures.md).
            False: the image grid's number.
        band_adds_only: each camera's detector keeps every spot its fixed rule passes, the
            band-pass only adding spots (``DetectorConfig.band_adds_only``, which this sets):
            bunched markers raise each other's local background, and a half-covered one beside
            them fell under the band-pass's bar. Off by default (session 26, detect26: grey
            sand tuning looks 85.3 -> 89.0 % and 67.4 -> 76.4 % numbered right, switches 22 ->
            3; the seed held apart's grey look 96.6 -> 94.9 %, 3D RMS 0.97 -> 1.25 mm:
            docs/figures.md). False: the band-pass's bar for every spot.
        contrast_faint: each camera's detector looks beside a numbered track's prediction,
            in normal light, for a faint marker by its contrast to the window's own sand, kept
            where it lies apart from the frame's spots and shows a share of a whole marker
            (``DetectorConfig.contrast_faint``, which this sets;
            :mod:`~dempath_recon.tracking.contrast_faint`): JPEG and noise flatten a marker
            under the faint search's absolute bars. On by default (session 26, detect26: the
            tuned variations 97.69 -> 99.25 % numbered right, 0 switches and wrong pairs, 3D
            RMS 1.449 -> 1.525 mm as the added points are half-covered markers; 36 burnt looks
            switches 197 -> 190; the seed held apart unchanged: docs/figures.md). False: the
            absolute bars only.
    """

    detector: DetectorConfig = field(default_factory=DetectorConfig)
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    grid: MarkerGrid = field(default_factory=MarkerGrid)
    fps: float = 50.0
    epipolar_px: float = 4.0
    min_grid_markers: int = 3
    grid_gate_px: float = 12.0
    position_gate_m: float = 0.01
    doubt_link_px: float = 5.0
    max_speed_m_s: float = 2.0
    tool_speed_m_s: float = 0.0
    number_delay_frames: int = 5
    marker_diameter_m: float = 0.008
    shake: bool = True
    shake_reference: bool = False
    shake_shrink: bool = True
    shake_align: bool = False
    uncover: bool = True
    publish_gate: bool = True
    elimination: bool = True
    record_numbers: bool = False
    coming_out: bool = False
    numbered_partner: bool = True
    regain: bool = True
    crowded_pairs: bool = True
    crowd_give_back: bool = True
    half_ghost: bool = True
    merge_release: bool = True
    track_split: bool = False
    line_rival: bool = True
    whole_pass: bool = True
    joint_fill: bool = True
    piece_numbering: bool = False
    bed_numbering: bool = False
    bed_sheared: bool = True
    bed_after_fill: bool = True
    dim_spots: bool = False
    band_pass: bool = True
    smooth_centres: bool = False
    eager_split: bool = False
    flux_share: bool = True
    pass_audit: bool = True
    audit_renumber: bool = False
    carried_confirm: bool = False
    touch_confirm: bool = True
    touch_wait: bool = True
    touch_swap: bool = True
    smooth_paths: bool = True
    ray_rivals: bool = True
    band_adds_only: bool = False
    contrast_faint: bool = True

    def __post_init__(self) -> None:
        for name in ('fps', 'epipolar_px', 'grid_gate_px', 'position_gate_m',
                     'max_speed_m_s'):
            if not getattr(self, name) > 0:
                msg = f'{name}: must be > 0, got {getattr(self, name)!r}'
                raise ValueError(msg)
        if not 0 <= self.tool_speed_m_s < 20:
            msg = f'tool_speed_m_s: must be in [0, 20) m/s, got {self.tool_speed_m_s!r}'
            raise ValueError(msg)
        if not 0 <= self.marker_diameter_m < 0.1:
            msg = f'marker_diameter_m: must be in [0, 0.1), got {self.marker_diameter_m!r}'
            raise ValueError(msg)
        if self.number_delay_frames < 0:
            msg = f'number_delay_frames: must be >= 0, got {self.number_delay_frames!r}'
            raise ValueError(msg)
        if self.min_grid_markers < 1:
            msg = f'min_grid_markers: must be >= 1, got {self.min_grid_markers!r}'
            raise ValueError(msg)


class PixelFrame(NamedTuple):
    """Numbered marker pixels of one camera frame (what a PixelPoints message carries)."""

    camera: str
    stamp_s: float
    markers: NDArray[np.int32]  # (k,) marker numbers, -1 not identified
    uv: FloatArray  # (k, 2) px
    confidence: FloatArray  # (k,)
    events: tuple[str, ...]
    shake_px: FloatArray | None = None  # (2,) px: the image's estimated shift, taken off ``uv``
    # (None: not estimated; ``uv + shake_px`` is where the points were seen in the image)
    size_px: FloatArray | None = None  # (k,) px: the radius of gyration of the detected spot
    # each point took (``Detections.size_px``; a marker of a split blob: one disc's), NaN for a
    # point on no detection (a faint spot); None: not known. Two markers merged into one spot,
    # or a marker sinking, show in it before they show in the numbers
    mass: FloatArray | None = None  # (k,) chroma x px^2: the detected spot's integrated
    # likelihood (``Detections.mass``), NaN for a point on no detection; None: not known


@dataclass
class CameraCounts:
    """What happened to one camera's frames (the run report's rows)."""

    frames: int = 0
    undecodable: int = 0
    dropped: int = 0
    out_of_order: int = 0
    no_marker: int = 0
    detected: int = 0
    tracked: int = 0
    lost: int = 0
    reattached: int = 0
    numbered_by_epipolar: int = 0
    numbered_by_grid_late: int = 0
    numbered_by_pair: int = 0
    numbered_by_track_pair: int = 0  # numbered by a partner held on their line (track_pairs)
    numbered_by_elimination: int = 0  # one camera's, by the free grid point it started at
    numbered_by_carried: int = 0  # one camera's new track, by where the bed carried a marker
    numbered_by_regain: int = 0  # a number elimination took back for a jump, given back (regain)
    numbered_whole_pass: int = 0  # points numbered at the end from the whole pass (whole_pass)
    numbered_joint_fill: int = 0  # points numbered at the end from the 3D paths (joint_fill)
    numbered_pieces: int = 0  # points numbered at the end by their piece of track (pieces)
    numbered_by_bed: int = 0  # points numbered at the end by the bed's motion (bed_numbering)
    audit_renumbered: int = 0  # points the pass audit gave another marker's number (pass_audit)
    audit_withheld: int = 0  # numbered points the pass audit took out: off their 3D path
    carried_withheld: int = 0  # numbers carried over a break of a track, never confirmed by
    # the other camera after it, withheld at the pass's end (carried_numbers)
    touch_withheld: int = 0  # numbers of two markers that touched, not told apart by the other
    # camera after it, withheld at the pass's end (touching_exchange)
    touch_swapped: int = 0  # numbers of two markers that touched, which the other camera tells
    # apart exchanged after it, exchanged at the pass's end (touching_exchange, touch_swap)
    numbered_late: int = 0
    unnumbered: int = 0
    epipolar_conflicts: int = 0
    position_conflicts: int = 0
    motion_conflicts: int = 0
    withheld: int = 0
    pair_residual_px: float = 0.0
    drift_frames: int = 0
    unconfirmed: int = 0
    confirmed_alone: int = 0
    revoked: int = 0
    confirmed_late: int = 0  # points withheld for the other camera, given out once it confirmed
    merged: int = 0  # numbered points withheld: a neighbour lost beside them may share the spot
    gated: int = 0  # numbered points withheld as given out: their pair's 3D point jumped away
    shake_frames: int = 0  # frames whose image moved by more than 0.5 px (corrected)
    shake_max_px: float = 0.0  # largest estimated image shift [px]
    shake_unknown: int = 0  # frames whose image motion could not be estimated (not corrected)
    view_offset_px: float = 0.0  # the pass's mean image position off the calibration's view
    # [px] (its frames given: ``StereoMarkerTracker.add_reference``; 0: not measured)
    gaps_s: list[tuple[float, float]] = field(default_factory=list)
