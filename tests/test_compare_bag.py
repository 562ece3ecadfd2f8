"""dempath compare reads bags: MarkerPoints3D + ParticleStates in an MCAP bag score exactly like
the same trajectories from CSV (the bag path goes through the streaming accumulator)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from dempath.bagio import write_bag
from dempath.typestore import make_typestore
from dempath_compare.cli import compare_main
from dempath_compare.loaders import load_source
from dempath_compare.pipeline import compare_paths
from dempath_compare.records import MEASURED, MODEL, Track

EXAMPLE = Path(__file__).resolve().parents[1] / 'src/dempath_compare/dempath_compare/data/example'


def by_time(tracks: list[Track]) -> dict[float, list[tuple[Track, int]]]:
    """Samples grouped by time stamp: t -> [(track, sample index)]."""
    steps: dict[float, list[tuple[Track, int]]] = {}
    for track in tracks:
        for i, t in enumerate(track.times):
            steps.setdefault(float(t), []).append((track, i))
    return dict(sorted(steps.items()))


def bag_messages(store: Any, measured: list[Track], model: list[Track]) -> list[tuple]:
    """(topic, type, time_ns, message) of both sides, as a reconstruction and a simulation emit."""
    t = store.types
    header = t['std_msgs/msg/Header']
    out = []
    for time_s, items in by_time(measured).items():
        ns = round(time_s * 1e9)
        stamp = t['builtin_interfaces/msg/Time'](sec=ns // 10**9, nanosec=ns % 10**9)
        xyz = np.array([tr.positions[i] for tr, i in items])
        empty = np.full(len(items), np.nan)
        msg = t['dempath_msgs/msg/MarkerPoints3D'](
            header=header(stamp=stamp, frame_id='world'), method='dlt',
            marker_ids=np.array([tr.ident for tr, _ in items], np.int32),
            x=np.ascontiguousarray(xyz[:, 0]),
            y=np.ascontiguousarray(xyz[:, 1]), z=np.ascontiguousarray(xyz[:, 2]),
            sigma_x=empty, sigma_y=empty, sigma_z=empty,
            reprojection_error=empty.astype(np.float32))
        out.append(('/markers/points3d', 'dempath_msgs/msg/MarkerPoints3D', ns, msg))
    pose = t['geometry_msgs/msg/Pose'](position=t['geometry_msgs/msg/Point'](x=0.0, y=0.0, z=0.0),
                                       orientation=t['geometry_msgs/msg/Quaternion'](
                                           x=0.0, y=0.0, z=0.0, w=1.0))
    for time_s, items in by_time(model).items():
        ns = round(time_s * 1e9)
        stamp = t['builtin_interfaces/msg/Time'](sec=ns // 10**9, nanosec=ns % 10**9)
        n = len(items)
        msg = t['dempath_msgs/msg/ParticleStates'](
            header=header(stamp=stamp, frame_id='world'), run_id='model_1ms', sim_time=time_s,
            ids=np.array([tr.ident for tr, _ in items], np.uint32),
            roles=np.ones(n, np.uint8), marker_ids=np.array([tr.marker_id for tr, _ in items],
                                                            np.int32),
            positions=np.array([tr.positions[i] for tr, i in items]).ravel(),
            velocities=np.zeros(3 * n), radii=np.full(n, 0.002), tool_pose=pose)
        out.append(('/sim/particle_states', 'dempath_msgs/msg/ParticleStates', ns, msg))
    return sorted(out, key=lambda m: m[2])


@pytest.fixture
def example_bag(tmp_path: Path) -> Path:
    """The 1 m/s worked example written to an MCAP bag named like its experiment."""
    store = make_typestore()
    measured = load_source(EXAMPLE / 'experiment_1ms.csv', MEASURED)
    model = load_source(EXAMPLE / 'model_1ms.csv', MODEL)
    return write_bag(tmp_path / 'experiment_1ms', bag_messages(store, measured, model),
                     typestore=store)


def test_bag_scores_equal_csv_scores(example_bag: Path) -> None:
    """Same labels, same S_sum / RMSE / DTW and ranks from the bag as from the CSV files."""
    from_bag = compare_paths(example_bag, example_bag)
    from_csv = compare_paths(EXAMPLE / 'experiment_1ms.csv', EXAMPLE / 'model_1ms.csv')
    assert from_bag.measured.labels == from_csv.measured.labels
    assert from_bag.model.labels == from_csv.model.labels
    for name in ('s_sum', 'rmse', 'dtw'):
        np.testing.assert_allclose(getattr(from_bag.scores, name),
                                   getattr(from_csv.scores, name), rtol=1e-9)
    np.testing.assert_array_equal(from_bag.scores.rank, from_csv.scores.rank)


def test_cli_on_bag(example_bag: Path, tmp_path: Path,
                    capsys: pytest.CaptureFixture[str]) -> None:
    """dempath compare BAG BAG writes the workbook; a bag without the topic is one error line."""
    assert compare_main([str(example_bag), str(example_bag), '--out', str(tmp_path / 'o'),
                         '--no-plots']) == 0
    assert (tmp_path / 'o' / 'compare.xlsx').stat().st_size > 0
    store = make_typestore()
    only_model = write_bag(tmp_path / 'model_only', [
        m for m in bag_messages(store, [], load_source(EXAMPLE / 'model_1ms.csv', MODEL))],
        typestore=store)
    capsys.readouterr()
    assert compare_main([str(only_model), str(example_bag), '--out', str(tmp_path / 'p')]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'no dempath_msgs/msg/MarkerPoints3D topic' in err[0], err
