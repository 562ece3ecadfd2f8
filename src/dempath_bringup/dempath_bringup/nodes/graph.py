"""The demo's node graph: field bag -> player -> (detectors) -> reconstructor; simulator; comparer.

Two ways in: camera images (``GraphSpec.detect``: the player plays each camera's
CompressedImage and CameraInfo from ``start_offset_s`` on, one detector node per camera finds,
tracks and numbers the markers and publishes PixelPoints ``SOURCE_DETECTED``), or pixel points
already in the bag (clicked, ``SOURCE_CLICKED``). The recorder records every topic of the run
(``graph_topics``), the MarkerArrays for Foxglove and ``/diagnostics`` included. All nodes run
in one process on a :class:`~dempath.nodes.harness.RosHarness` (no launch); :func:`run_graph` is
the graph step of ``dempath demo`` and what the tests run on the tiny scene. The graph learns
what it needs through topics (the simulator's RunEvent) and the nodes' documented read-only
accessors: the recorder's ``received_counts()``, the player's ``published()``, each detector's
``handled_frames()`` and ``tracking_counts()``, the reconstructor's fitted ``reconstructor``, the
simulator's ``run_id`` and ``frames_published``, the comparer's ``last_result``. Also the checks
of its outputs against the field twin's truth.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from dempath.errors import DempathError

METHOD = 'dlt_refined'  # triangulation + Gauss-Newton in pixels: no training, < 1 s to fit
WARN = 30  # rcutils log level WARN: the nodes stay quiet unless something is wrong
QUIET_NODES = ('dempath_reconstructor', 'dempath_comparer', 'dempath_recorder', 'dempath_player',
               'dempath_simulator', 'cam_side.dempath_detector', 'cam_front.dempath_detector')
IMAGE_READERS = 3  # readers of an image topic here: both lossless detectors and the recorder
WHOLE_PASS_QUEUE = 10_000  # frames a camera (200 s at 50 FPS) the reconstructor keeps waiting
SETTLE_S = 5.0  # images all detected and no new 3D frame for this long: the playback is done [s]
# (with 1.5 s a loaded CI run once ended with 25 of 31 frame pairs; cause not traced)
SCORE_GRACE_SPINS = 200  # executor spins (0.05 s each when idle) to wait for scores after
# the model run ended


@dataclass(frozen=True)
class GraphSpec:
    """What the node graph runs.

    Attributes:
        field_bag: bag with PixelPoints of both cameras (and optional image previews).
        calibration: stereo calibration YAML for the reconstructor.
        scene: model scene (file or shipped name), run with its own effects.
        output: bag folder the recorder creates.
        method: reconstruction method of the reconstructor node.
        rate: playback speed factor of the field bag (0: as fast as possible).
        experiment: name of the measured experiment in the scores.
        cache_dir: packing cache of the simulator ('' for the default).
        play_timeout_s: longest wait for the playback and its 3D points [s].
        sim_timeout_s: longest wait for the simulation and its scores [s].
        detect: detect the markers in the bag's images (else play its pixel points).
        start_offset_s: skip this much of the bag's start (its calibration segment) [s].
        viz_every: the simulator's MarkerArray every this many frames.
    """

    field_bag: Path
    calibration: Path
    scene: str
    output: Path
    method: str = METHOD
    rate: float = 1.0
    experiment: str = 'field_twin'
    cache_dir: str = ''
    play_timeout_s: float = 120.0
    sim_timeout_s: float = 3600.0
    detect: bool = False
    start_offset_s: float = 0.0
    viz_every: int = 1


@dataclass
class GraphResult:
    """What the graph did: counts per topic (as recorded), scores and the recorder summary.

    Attributes:
        reconstructor: the reconstructor node's fitted method (fitted once, by the node).
        live: the comparer node's comparison behind its published scores (None: no scores).
    """

    bag: Path
    received: dict[str, int]
    pixel_frames: int
    run_id: str
    sim_frames: int
    scores: int
    scored_markers: int
    summary: str
    wall_s: float
    reconstructor: Any = None
    live: Any = None
    detection: dict[str, Any] = field(default_factory=dict)
    play_s: float = 0.0
    sim_s: float = 0.0

    def text(self) -> str:
        """A few printable lines."""
        from dempath import topics

        got = self.received.get
        what = 'detected' if self.detection else 'clicked'
        return (f'{self.pixel_frames} {what} frame pairs -> {got(topics.MARKER_POINTS, 0)} '
                f'MarkerPoints3D; model run {self.run_id}: {self.sim_frames} ParticleStates; '
                f'comparer: {self.scores} scores for {self.scored_markers} markers\n'
                f'recorded {sum(self.received.values())} messages on {len(self.received)} '
                f'topics into {self.bag} ({self.wall_s:.1f} s: playback and detection '
                f'{self.play_s:.1f} s, model run and scores {self.sim_s:.1f} s)')


def _received(recorder: Any, topic: str) -> int:
    return int(recorder.received_counts().get(topic, 0))


def _play(harness: Any, recorder: Any, spec: GraphSpec, note: Callable[[str], None]) -> int:
    """Play the field bag; wait until the reconstructor's points of every pair are recorded."""
    from dempath import topics
    from dempath.nodes.player import PlayerNode

    pixel = [topics.camera_topic(topics.PIXEL_POINTS, c) for c in topics.CAMERAS]
    # the reconstructor and the recorder read the pixel points: wait for both (see _play_images)
    harness.spin_until(lambda: all(recorder.subscribed_to(t) for t in pixel), timeout_s=10.0,
                       step_s=0.02)
    player = harness.start(PlayerNode, bag=str(spec.field_bag), rate=float(spec.rate),
                           wait_for_subscribers=1,
                           wait_topic_subscribers=[f'{t}=2' for t in pixel])

    def expected() -> int:
        published = player.published()
        return min(int(published.get(t, 0)) for t in pixel)

    def done() -> bool:
        note(f'playing {spec.field_bag.name}: '
             f'{_received(recorder, topics.MARKER_POINTS)} MarkerPoints3D')
        return player.finished.is_set() and \
            _received(recorder, topics.MARKER_POINTS) >= expected()

    if not harness.spin_until(done, timeout_s=spec.play_timeout_s, step_s=0.02):
        msg = (f'{spec.field_bag}: playback incomplete after {spec.play_timeout_s} s '
               f'({_received(recorder, topics.MARKER_POINTS)} of {expected()} 3D frames)')
        raise DempathError(msg)
    return expected()


def graph_topics() -> list[str]:
    """Every topic the demo's graph publishes (what the recorder records)."""
    from dempath import topics

    per_camera = (topics.IMAGE_COMPRESSED, topics.CAMERA_INFO, topics.PIXEL_POINTS)
    names = [topics.camera_topic(t, c) for t in per_camera for c in topics.CAMERAS]
    names += [topics.MARKER_POINTS, topics.MARKER_VIZ, topics.SIM_STATES, topics.SIM_TOOL_FORCE,
              topics.SIM_TOOL_POSE, topics.SIM_RUN_EVENTS, topics.SIM_VIZ, topics.COMPARE_SCORES,
              topics.COMPARE_VIZ, topics.PLAYER_EVENTS, topics.DIAGNOSTICS,
              topics.SIM_TOOL_WRENCH, topics.SIM_CLOUD]
    return names


def _start_detectors(harness: Any, spec: GraphSpec) -> dict[str, Any]:
    """One detector node per camera (namespaced by the camera: two nodes of one class)."""
    from rclpy.parameter import Parameter

    from dempath import topics
    from dempath_recon.nodes.detector import DetectorNode

    nodes = {}
    for cam in topics.CAMERAS:
        params = [Parameter('camera', value=cam),
                  Parameter('calibration_file', value=str(spec.calibration)),
                  Parameter('lossless', value=True)]  # a bag: every frame, none dropped
        nodes[cam] = harness.add(DetectorNode(context=harness.context, namespace=cam,
                                              parameter_overrides=params))
    return nodes


def _play_images(harness: Any, recorder: Any, spec: GraphSpec, detectors: dict[str, Any],
                 note: Callable[[str], None]) -> int:
    """Play the bag's images from the offset; wait until every image is detected and the 3D
    frames stop coming. Returns the number of 3D frames (detected pairs)."""
    from dempath import topics
    from dempath.nodes.player import PlayerNode

    images = {c: topics.camera_topic(topics.IMAGE_COMPRESSED, c) for c in topics.CAMERAS}
    infos = [topics.camera_topic(topics.CAMERA_INFO, c) for c in topics.CAMERAS]
    # The recorder subscribes to a topic when it discovers it (here: the detectors' subscriptions
    # of the images). Each image has three readers: both lossless detectors and the recorder; a
    # publisher matches them one by one, so the player waits for all three, or an image may go
    # out before the recorder has matched (it lost the first side image on a loaded machine when
    # the player waited for one reader and this wait counted the two detectors as enough)
    harness.spin_until(lambda: all(recorder.subscribed_to(t) for t in images.values()),
                       timeout_s=10.0, step_s=0.02)
    player = harness.start(PlayerNode, bag=str(spec.field_bag), rate=float(spec.rate),
                           start_offset_s=float(spec.start_offset_s),
                           topics=list(images.values()) + infos, wait_for_subscribers=1,
                           wait_topic_subscribers=[f'{t}={IMAGE_READERS}'
                                                   for t in images.values()])
    last = [-1, time.monotonic()]

    def detected(cam: str) -> int:  # skipped frames included: the demo must not wait for them
        return int(detectors[cam].handled_frames())

    def done() -> bool:
        points = _received(recorder, topics.MARKER_POINTS)
        note(f'detecting in {spec.field_bag.name}: frames ' + ', '.join(
            f'{c} {detected(c)}' for c in images) + f'; {points} MarkerPoints3D')
        # the settling time runs from the last new 3D frame or detected frame: a detector that
        # holds the whole pass (whole_pass) gives every frame out at once when it ends
        seen = points + sum(detected(c) for c in images)
        if seen != last[0]:
            last[:] = [seen, time.monotonic()]
        if not player.finished.is_set():
            return False
        published = player.published()
        return all(detected(c) >= published.get(t, 0) for c, t in images.items()) and \
            time.monotonic() - last[1] > SETTLE_S

    if not harness.spin_until(done, timeout_s=spec.play_timeout_s, step_s=0.02):
        msg = (f'{spec.field_bag}: detection incomplete after {spec.play_timeout_s} s ('
               + ', '.join(f'{c} {detected(c)} frames' for c in images) + ')')
        raise DempathError(msg)
    return _received(recorder, topics.MARKER_POINTS)


def _simulate(harness: Any, recorder: Any, spec: GraphSpec,
              note: Callable[[str], None]) -> Any:
    """Run the simulator node; wait until the comparer's scores are recorded."""
    from rclpy.qos import DurabilityPolicy, QoSProfile

    from dempath import topics
    from dempath_msgs.msg import RunEvent
    from dempath_sim.nodes.simulator import SimulatorNode

    latched = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    events = harness.collect(RunEvent, topics.SIM_RUN_EVENTS, latched)
    sim = harness.start(SimulatorNode, scene=spec.scene, cache_dir=spec.cache_dir,
                        viz_every=spec.viz_every, wait_for_subscribers=1)  # the recorder
    start = time.monotonic()
    idle_spins: list[int] = []  # spins since the run ended: counted, not timed, because the
    # comparer scores inside a callback and a loaded machine can take longer than any grace

    def done() -> bool:
        frames = sim.frames_published
        what = f'{frames} frames' if frames else 'fill or cached packing'
        note(f'simulating {spec.scene}: {what}, {time.monotonic() - start:.0f} s')
        if _received(recorder, topics.COMPARE_SCORES) > 0:
            return True
        if any(e.event in (RunEvent.FINISHED, RunEvent.ABORTED) for e in events):
            idle_spins.append(1)
        return len(idle_spins) > SCORE_GRACE_SPINS

    harness.spin_until(done, timeout_s=spec.sim_timeout_s, step_s=0.05)
    if _received(recorder, topics.COMPARE_SCORES) == 0:
        msg = f'{spec.scene}: no scores after the model run (see the log above)'
        raise DempathError(msg)
    return sim


def run_graph(spec: GraphSpec, note: Callable[[str], None] = lambda text: None) -> GraphResult:
    """Field bag -> player -> reconstructor -> comparer <- simulator; recorder records all.

    Raises:
        DempathError: a node cannot start, the playback or the run does not complete.
    """
    from dempath.nodes.harness import RosHarness
    from dempath.nodes.recorder import RecorderNode
    from dempath_bringup.frames import write_graph_frames
    from dempath_compare.nodes.comparer import ComparerNode
    from dempath_recon.nodes.reconstructor import ReconstructorNode

    start = time.monotonic()
    if spec.detect:
        spec = fitted_calibration(spec, note)
    with RosHarness() as harness:
        logger_class = type(harness.probe.get_logger())  # type: ignore[no-untyped-call]  # rcutils logger
        for name in QUIET_NODES:
            logger_class(name).set_level(WARN)
        # detecting (lossless, whole_pass), each detector gives its camera's whole pass out at
        # once when the images end: the reconstructor keeps every frame till its partner comes
        recon = harness.start(ReconstructorNode, method=spec.method,
                              calibration_file=str(spec.calibration),
                              **({'queue_size': WHOLE_PASS_QUEUE,
                                  'subscription_depth': WHOLE_PASS_QUEUE} if spec.detect else {}))
        comparer = harness.start(ComparerNode, experiment=spec.experiment,
                                 identity_from_names=True)  # as stages.named_identity
        frames = write_graph_frames(spec.output.with_name(f'{spec.output.name}.frames.yaml'),
                                    spec.calibration, spec.scene)  # /tf_static of the bag
        recorder = harness.start(RecorderNode, output=str(spec.output), topics=graph_topics(),
                                 frames_file=str(frames))
        if not recorder.recording:
            msg = f'{spec.output}: the recorder cannot write the bag'
            raise DempathError(msg)
        detection: dict[str, Any] = {}
        if spec.detect:
            detectors = _start_detectors(harness, spec)
            pixel_frames = _play_images(harness, recorder, spec, detectors, note)
            detection = {c: n.tracking_counts() for c, n in detectors.items()}
        else:
            pixel_frames = _play(harness, recorder, spec, note)
        play_s = time.monotonic() - start
        sim = _simulate(harness, recorder, spec, note)
        sim_s = time.monotonic() - start - play_s
        received = recorder.received_counts()
        summary = recorder.finish()
        run_id, frames = sim.run_id, sim.frames_published
    scores, markers = recorded_scores(spec.output)
    return GraphResult(spec.output, received, pixel_frames, run_id, frames, scores, markers,
                       summary, time.monotonic() - start, recon.reconstructor,
                       comparer.last_result, detection, play_s, sim_s)


def recording_sizes(bag: Path) -> dict[str, tuple[int, int]]:
    """{camera: (width, height) px} of the first compressed image of each camera in ``bag``."""
    import cv2

    from dempath import topics
    from dempath.bagio import open_bag

    wanted = {topics.camera_topic(topics.IMAGE_COMPRESSED, c): c for c in topics.CAMERAS}
    sizes: dict[str, tuple[int, int]] = {}
    with open_bag(bag) as reader:
        names = [t for t in wanted if t in reader.topics]
        for raw in reader.messages(names):
            cam = wanted[raw.topic]
            if cam in sizes:
                if len(sizes) == len(names):
                    break
                continue
            image = cv2.imdecode(np.asarray(reader.deserialize(raw).data, np.uint8),
                                 cv2.IMREAD_GRAYSCALE)
            if image is not None:
                sizes[cam] = (int(image.shape[1]), int(image.shape[0]))
    return sizes


def fitted_calibration(spec: GraphSpec, note: Callable[[str], None]) -> GraphSpec:
    """``spec`` with a calibration that fits the recording's image size: the same one, or one
    scaled to a recording of the same aspect ratio (saved beside the output bag and said);
    CalibrationError (one line naming both sizes) for another aspect ratio."""
    from dempath_calib.camera import StereoCalibration
    from dempath_calib.resize import fit_to_images

    calib = StereoCalibration.load(spec.calibration)
    fitted, notes = fit_to_images(calib, recording_sizes(spec.field_bag), str(spec.field_bag))
    if not notes:
        return spec
    path = fitted.save(spec.output.parent / f'{spec.output.name}.calibration_scaled.yaml')
    for line in notes:
        logging.getLogger(__name__).warning('%s: %s', spec.field_bag, line)
        note(line)
    return replace(spec, calibration=path)


def recorded_scores(bag: Path) -> tuple[int, int]:
    """(valid scores, markers with a valid score) in the bag's TrajectoryScoreArray messages."""
    from dempath import topics
    from dempath.bagio import open_bag

    count, markers = 0, set()
    with open_bag(bag, [topics.COMPARE_SCORES]) as reader:
        for raw in reader.messages([topics.COMPARE_SCORES]):
            for score in reader.deserialize(raw).scores:
                if score.valid:
                    count += 1
                    markers.add(int(score.marker_id))
    return count, len(markers)


def field_truth_error(bag: Path, truth_csv: Path) -> tuple[float, float, float]:
    """(mean, max, RMS) mm distance of the recorded MarkerPoints3D from the field twin's truth."""
    from dempath import topics
    from dempath.bagio import open_bag
    from dempath_twin.field.markers import START_NS, read_marker_csv

    truth = read_marker_csv(truth_csv)
    frame = {round(t * 1e4): k for k, t in enumerate(truth.times)}
    column = {int(m): j for j, m in enumerate(truth.marker_ids)}
    errors = []
    with open_bag(bag, [topics.MARKER_POINTS]) as reader:
        for raw in reader.messages([topics.MARKER_POINTS]):
            msg = reader.deserialize(raw)
            t_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec - START_NS
            k = frame.get(round(t_ns * 1e-5))
            for m, x, y, z in zip(msg.marker_ids, msg.x, msg.y, msg.z, strict=True):
                if k is not None and int(m) in column:
                    errors.append(np.linalg.norm(np.array([x, y, z]) - truth.xyz[k, column[m]]))
    if not errors:
        msg = f'{bag}: no MarkerPoints3D at the stamps of {truth_csv}'
        raise DempathError(msg)
    err_mm = 1e3 * np.asarray(errors)
    return (float(np.nanmean(err_mm)), float(np.nanmax(err_mm)),
            float(np.sqrt(np.nanmean(err_mm ** 2))))
