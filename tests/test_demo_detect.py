"""The demo from camera images: calibration from the rendered recording's board segment, then
the graph with a detector node per camera, on the bundled render (model: the tiny scene).

Checks the calibration against the recording's truth file, the reconstructed markers against
the true ones, that every topic of the run (MarkerArrays for Foxglove and /diagnostics
included) is in the MCAP bag, and that a camera topic stopping mid-pass is reported while the
rest of the run goes on.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from dempath import topics
from dempath.bagio import filter_bag
from dempath_bringup.calibstep import (
    CalibrationRun,
    calibrate_recording,
    check_against_truth,
    truth_cameras,
)
from dempath_bringup.nodes.graph import GraphSpec, run_graph
from dempath_bringup.stages import START_MARGIN_S, detection_lines
from dempath_bringup.truth import render_truth_errors, surface_coverage
from dempath_calib.outputs import save_result

# calibration and three graph runs with the model: long on a loaded machine
pytestmark = pytest.mark.timeout(1800)
ROOT = Path(__file__).resolve().parents[1]
RENDER = ROOT / 'bags' / 'field_render_reduced_1ms'
TRUTH = RENDER.with_name(RENDER.name + '.truth.json')
# calibration against the truth (the twin calibration's bars, docs/calibration.md, widened for
# the few views of the bundled recording)
# About ten board views per camera: the principal point is found to a few pixels, and a shift
# of it trades against the orientation (5 px at f = 920 px is 0.3 deg); centre and 3D bound both.
TOL = {'fx_pct': 1.0, 'fy_pct': 1.0, 'cx_px': 8.0, 'cy_px': 8.0, 'centre_mm': 8.0,
       'angle_deg': 0.5}
RATE = 0.25  # playback speed (the demo's)


@pytest.fixture(scope='module')
def calibrated(tmp_path_factory: pytest.TempPathFactory) -> tuple[CalibrationRun, Path]:
    """The render's board segment calibrated once for the module; (run, stereo YAML)."""
    run = calibrate_recording(RENDER, lambda *_: None)
    out = tmp_path_factory.mktemp('calib')
    return run, save_result(run.result, out, {'inputs': [str(RENDER)]})['stereo.yaml']


def mcap_topic_counts(bag: Path) -> Counter[str]:
    """Messages per topic, read with the mcap package's own reader."""
    counts: Counter[str] = Counter()
    for path in bag.glob('*.mcap'):
        with path.open('rb') as f:
            for _, channel, _ in make_reader(f).iter_messages():
                counts[channel.topic] += 1
    return counts


def test_calibration_from_the_board_segment(calibrated: tuple[CalibrationRun, Path]) -> None:
    """Both cameras within the bars of the truth; the field segment starts where the truth says."""
    run, _ = calibrated
    rows = check_against_truth(run.result.calibration, truth_cameras(TRUTH))
    assert {r['camera'] for r in rows} == {'cam_side', 'cam_front'}
    for r in rows:
        for key, bar in TOL.items():
            assert abs(r[key]) < bar, f"{r['camera']} {key} {r[key]:.3f} (bar {bar})"
    truth = json.loads(TRUTH.read_text())
    first_field = min(f['stamp_ns'] for f in truth['frames']) * 1e-9
    assert run.field_start_s is not None
    assert abs(run.field_start_s - first_field) < 1e-6
    assert max(s for _, s in run.board_stamps) < run.field_start_s


def test_graph_detects_reconstructs_and_records_everything(
        calibrated: tuple[CalibrationRun, Path], tmp_path: Path) -> None:
    """Images -> detectors -> 3D within a few mm of the truth; the run's topics all recorded."""
    run, stereo = calibrated
    offset = run.field_start_s - run.first_stamp_s - START_MARGIN_S  # type: ignore[operator]
    spec = GraphSpec(field_bag=RENDER, calibration=stereo, scene='tiny', output=tmp_path / 'run',
                     rate=RATE, detect=True, start_offset_s=offset, sim_timeout_s=600.0)
    result = run_graph(spec)
    truth = json.loads(TRUTH.read_text())
    per_camera = Counter(f['camera'] for f in truth['frames'])
    assert {c: r['frames'] for c, r in result.detection.items()} == dict(per_camera)
    assert result.pixel_frames >= min(per_camera.values()) - 1
    err_mm = render_truth_errors(result.bag, TRUTH)
    # The rendered recording has one point (of ~340) numbered as a marker 130 mm from it in both
    # cameras (a consistent false match, reprojection 1 px; a known detector defect, README):
    # the bar is on the bulk and on how rare such points are, not on the RMS they dominate.
    assert float(np.median(err_mm)) < 2.0, f'median 3D error {np.median(err_mm):.2f} mm'
    assert float(np.mean(err_mm > 10.0)) <= 0.01, f'{int((err_mm > 10.0).sum())} points > 10 mm'
    counts = mcap_topic_counts(result.bag)
    for topic in (topics.MARKER_POINTS, topics.MARKER_VIZ, topics.SIM_STATES, topics.SIM_VIZ,
                  topics.SIM_TOOL_POSE, topics.SIM_TOOL_FORCE, topics.COMPARE_SCORES,
                  topics.DIAGNOSTICS, '/cam_side/image_raw/compressed',
                  '/cam_front/pixel_points'):
        assert counts[topic] > 0, f'{topic} not recorded: {dict(counts)}'
    assert counts['/cam_side/image_raw/compressed'] == per_camera['cam_side']
    # the simulator holds its first frame until the recorder has subscribed: every one recorded
    assert counts[topics.SIM_VIZ] == result.sim_frames
    # every marker both cameras see (at least half of it) through a third of the pass is scored
    side, front = ([np.asarray(f['visible']) > 0.5 for f in truth['frames'] if f['camera'] == c]
                   for c in ('cam_side', 'cam_front'))
    seen = (np.array(side) & np.array(front)).sum(0)
    assert result.scored_markers >= int(np.sum(seen >= len(side) / 3)), seen
    # issue 26: on the bundled twin at least 13 of 15 markers become 3D in >= 80 % of the frames
    # the truth has them on the surface (the carriage rig; the fixed rig gave 8)
    got, total = surface_coverage(result.bag, TRUTH) or (0, 0)
    assert total == 15 and got >= 13, (got, total)


def test_camera_topic_stopping_mid_pass(calibrated: tuple[CalibrationRun, Path],
                                        tmp_path: Path) -> None:
    """The front camera's images stop halfway: reported in one warning, the run goes on."""
    run, stereo = calibrated
    truth = json.loads(TRUTH.read_text())
    front = sorted(f['stamp_ns'] for f in truth['frames'] if f['camera'] == 'cam_front')
    cut = front[len(front) // 2]
    bag = filter_bag(RENDER, tmp_path / 'stops', lambda topic, stamp: not (
        topic.startswith('/cam_front/') and stamp >= cut))
    offset = run.field_start_s - run.first_stamp_s - START_MARGIN_S  # type: ignore[operator]
    spec = GraphSpec(field_bag=bag, calibration=stereo, scene='tiny', output=tmp_path / 'run',
                     rate=RATE, detect=True, start_offset_s=offset, sim_timeout_s=600.0)
    result = run_graph(spec)
    assert result.detection['cam_front']['frames'] == len(front) // 2
    assert result.detection['cam_side']['frames'] == len(front)
    warnings = [ln for ln in detection_lines(result.detection) if ln.startswith('warning:')]
    assert len(warnings) == 1 and 'cam_front' in warnings[0], warnings
    assert 0 < result.received[topics.MARKER_POINTS] <= len(front) // 2 + 1
    assert result.sim_frames > 0 and result.scored_markers > 0  # the model still runs, scored
