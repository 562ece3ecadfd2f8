"""The demo's node graph end to end on a few field-twin frames and the tiny scene."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
from mcap.reader import make_reader

from dempath import topics
from dempath.bagio import make_typestore, write_bag
from dempath_bringup.nodes.graph import GraphSpec, field_truth_error, run_graph
from dempath_twin.field import markers as ft
from dempath_twin.rig import paper_rig

ROOT = Path(__file__).resolve().parents[1]
TRUTH = ROOT / 'bags' / 'field_twin_tiny.truth.csv'
STRIDE = 3  # every 3rd frame of the shipped field twin: a few frames over the whole motion


def few_frames_bag(tmp_path: Path) -> tuple[Path, Path, int]:
    """A field bag of every STRIDE-th truth frame with fresh clicking noise, and its truth CSV."""
    truth = ft.read_marker_csv(TRUTH)
    tracks = ft.MarkerTracks(truth.times[::STRIDE], truth.marker_ids, truth.xyz[::STRIDE])
    rig, config = paper_rig(), ft.FieldTwinConfig(seed=3, image_scale=0.25)
    clicked = ft.click_noise(ft.project_tracks(rig.cameras, tracks.xyz), config.sigma_px,
                             np.random.default_rng(3))
    store = make_typestore()
    bag = write_bag(tmp_path / 'field', ft.field_messages(tracks, rig.cameras, clicked, config,
                                                          store.types), typestore=store)
    return bag, ft.write_truth_csv(tmp_path / 'truth.csv', tracks), len(tracks.times)


def mcap_topic_counts(bag: Path) -> Counter[str]:
    """Messages per topic, read with the mcap package's own reader (not rosbags)."""
    counts: Counter[str] = Counter()
    for path in bag.glob('*.mcap'):
        with path.open('rb') as f:
            for _, channel, _ in make_reader(f).iter_messages():
                counts[channel.topic] += 1
    return counts


def test_graph_reconstructs_simulates_and_scores(tmp_path: Path) -> None:
    """Clicks -> 3D within a few mm of the truth; the tiny run is scored for all 15 markers."""
    field, truth_csv, frames = few_frames_bag(tmp_path)
    calibration = paper_rig().save(tmp_path / 'stereo.yaml')
    spec = GraphSpec(field_bag=field, calibration=calibration, scene='tiny',
                     output=tmp_path / 'run', experiment='field_twin', sim_timeout_s=300.0)
    result = run_graph(spec)
    assert result.pixel_frames == frames
    assert result.received[topics.MARKER_POINTS] == frames
    mean_mm, max_mm, _ = field_truth_error(result.bag, truth_csv)
    assert mean_mm < 5.0, f'mean 3D error {mean_mm:.2f} mm'
    assert max_mm < 15.0, f'max 3D error {max_mm:.2f} mm'
    assert result.scored_markers == 15
    assert result.scores >= 15
    assert result.sim_frames > 10
    assert result.live is not None and len(result.live.measured) == 15  # the node's own scores
    counts = mcap_topic_counts(result.bag)
    assert counts[topics.MARKER_POINTS] == frames
    assert counts[topics.SIM_STATES] == result.sim_frames
    assert counts[topics.COMPARE_SCORES] >= 1
    assert counts[topics.SIM_RUN_EVENTS] >= 2  # STARTED and FINISHED
    assert counts[topics.camera_topic(topics.PIXEL_POINTS, 'cam_side')] == frames
