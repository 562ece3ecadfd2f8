"""The diagnosis node, launch-free: a measured pass in, a Diagnosis out when the pass ends."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dempath import topics
from dempath_diagnose.decision.live import measurement_from_frames
from dempath_diagnose.decision.measure import load_force, load_tracks
from dempath_diagnose.library.store import Library
from dempath_diagnose.nodes.diagnoser import DiagnoserNode
from dempath_msgs.msg import Diagnosis, MarkerPoints3D, RunEvent, ToolForce

from .conftest import SCENE
from .test_hidden import case_files


def marker_msgs(times: np.ndarray, markers: np.ndarray, pos: np.ndarray) -> list[MarkerPoints3D]:
    """One MarkerPoints3D per time (stamps = pass time)."""
    out = []
    for i, t in enumerate(times):
        msg = MarkerPoints3D(method='dlt', marker_ids=[int(m) for m in markers])
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), round((t % 1) * 1e9)
        msg.x, msg.y, msg.z = (pos[i, :, a].tolist() for a in range(3))
        out.append(msg)
    return out


def force_msgs(times: np.ndarray, force: np.ndarray) -> list[ToolForce]:
    """One ToolForce per sample."""
    out = []
    for t, f in zip(times, force, strict=True):
        msg = ToolForce(run_id='measured', sim_time=float(t), draft_force=float(-f[2]))
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), round((t % 1) * 1e9)
        msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = (float(v) for v in f)
        out.append(msg)
    return out


def test_streaming_and_batch_measurements_agree(cache: Path) -> None:
    """Frames fed one by one give the Measurement the CSV loader gives."""
    markers, _ = case_files(cache, 'tool_speed')
    batch = load_tracks(markers)
    frames = [(float(t), batch.markers, batch.positions[i]) for i, t in enumerate(batch.times)]
    live = measurement_from_frames(frames)
    assert np.array_equal(live.markers, batch.markers)
    assert np.allclose(live.positions, batch.positions, equal_nan=True)


def test_node_publishes_a_diagnosis_when_the_pass_ends(ros_harness: Any, cache: Path,
                                                       tiny_library: Library,
                                                       tmp_path: Path) -> None:
    """The tool-speed case played on the topics, one marker held out: a Diagnosis naming
    tool_speed first from the others, with what diagnosis.json holds and the held-out marker's
    headline error apart; the recorder records it to MCAP."""
    from dempath.bagio import open_bag
    from dempath.nodes.recorder import RecorderNode

    markers, force = case_files(cache, 'tool_speed')
    meas = load_tracks(markers)
    t_force, f = load_force(force)
    held = int(meas.markers[len(meas.markers) // 2])
    node = ros_harness.start(DiagnoserNode, scene=SCENE, library=str(tiny_library.folder),
                             held_out=str(held))
    recorder = ros_harness.start(RecorderNode, output=str(tmp_path / 'bag'),
                                 topics=[topics.DIAGNOSIS])
    assert ros_harness.spin_until(lambda: topics.DIAGNOSIS in recorder._topic_subs,
                                  timeout_s=30), 'the recorder never subscribed to /diagnosis'
    got = ros_harness.collect(Diagnosis, topics.DIAGNOSIS)
    pm = ros_harness.publisher(MarkerPoints3D, topics.MARKER_POINTS, 1000)
    pf = ros_harness.publisher(ToolForce, '/markers/tool_force', 1000)
    pe = ros_harness.publisher(RunEvent, topics.PLAYER_EVENTS)
    for pub in (pm, pf, pe):
        assert ros_harness.wait_for_subscribers(pub)
    step = slice(None, None, 2)  # 100 Hz of frames
    ros_harness.publish_all(pm, marker_msgs(meas.times[step], meas.markers,
                                            meas.positions[step]))
    ros_harness.publish_all(pf, force_msgs(t_force, f))
    n = len(meas.times[step])
    assert ros_harness.spin_until(lambda: len(node.core.frames) == n, timeout_s=20)
    pe.publish(RunEvent(run_id='case_tool_speed', event=RunEvent.FINISHED))
    assert ros_harness.spin_until(lambda: bool(got), timeout_s=120), 'no Diagnosis published'
    msg = got[0]
    assert msg.case_id == 'case_tool_speed'
    assert msg.verdict.startswith('parameter_off'), msg.verdict
    assert msg.candidates[0].effect == 'tool_speed'
    assert msg.candidates[0].probability >= 0.8
    assert msg.candidates[0].strength_parameter == 'speed_scale'
    check_fields(msg, len(tiny_library.runs))
    # the held-out marker: scored apart, beside its own like-for-like floor band
    assert list(msg.held_out_markers) == [held]
    assert msg.held_out_place in ('above', 'in', 'below')
    assert msg.held_out_floor_low_mm < msg.held_out_floor_high_mm
    assert np.isfinite(msg.held_out_headline_error_mm)
    assert ros_harness.spin_until(
        lambda: recorder.recorder.stats.get(topics.DIAGNOSIS) is not None
        and recorder.recorder.stats[topics.DIAGNOSIS].received >= 1, timeout_s=30)
    recorder.finish()
    with open_bag(tmp_path / 'bag') as bag:
        recorded = [bag.deserialize(m) for m in bag.messages([topics.DIAGNOSIS])]
    assert len(recorded) == 1
    assert recorded[0].verdict_code == 'parameter_off'
    assert recorded[0].candidates[0].effect == 'tool_speed'
    assert list(recorded[0].statistic_names) == list(msg.statistic_names)


def check_fields(msg: Diagnosis, runs: int) -> None:
    """The fields diagnosis.json holds are filled and consistent."""
    assert msg.verdict_code == 'parameter_off'
    assert msg.summary and msg.verdict.endswith(msg.summary[0])
    assert 0.0 <= msg.baseline_probability < 0.2 and msg.baseline_implausibility >= 0.0
    k = len(msg.statistic_names)
    assert k > 0 and len(msg.floor) == len(msg.measured) == len(msg.model) == k
    assert all(v > 0 for v in msg.floor)
    assert any(n.startswith('force:draft') for n in msg.statistic_names)
    assert np.all(np.isfinite(msg.measured))  # the force was measured: every statistic is
    assert np.isfinite(msg.mean_nrmse_pct) and msg.mean_nrmse_pct > 0
    # the headline error on the live topic, beside its like-for-like floor band
    assert msg.headline_place == 'above', msg.headline_place  # the tool speed is off
    assert msg.headline_floor_low_mm < msg.headline_floor_high_mm < msg.headline_error_mm
    assert msg.simulations == runs and msg.wall_s > 0
    assert not msg.remaining  # named, not inconclusive
    top = msg.candidates[0]
    assert top.kind == 'parameter' and top.strength_unit == '1'
    assert top.strength_uncertainty > 0 and not top.ruled_out
    total = msg.baseline_probability + sum(c.probability for c in msg.candidates)
    assert abs(total - 1.0) < 1e-6


def test_cli_reads_a_bag_of_marker_points(cache: Path, tiny_library: Library,
                                          tmp_path: Path) -> None:
    """The tool-speed case as a bag of MarkerPoints3D (the reconstructor's output): named."""
    import json

    from dempath.bagio import write_bag
    from dempath.typestore import make_typestore
    from dempath_diagnose.cli import diagnose_main

    from .conftest import SPEC

    markers, force = case_files(cache, 'tool_speed')
    meas = load_tracks(markers)
    store = make_typestore()
    point, header = (store.types['dempath_msgs/msg/MarkerPoints3D'],
                     store.types['std_msgs/msg/Header'])
    stamp = store.types['builtin_interfaces/msg/Time']
    nan = np.full(len(meas.markers), np.nan)
    msgs = []
    for i, t in enumerate(meas.times[::2]):
        p = meas.positions[2 * i]
        ns = round(float(t) * 1e9)
        msg = point(header=header(stamp=stamp(sec=ns // 10**9, nanosec=ns % 10**9),
                                  frame_id='world'), method='dlt',
                    marker_ids=meas.markers.astype(np.int32), x=np.ascontiguousarray(p[:, 0]),
                    y=np.ascontiguousarray(p[:, 1]), z=np.ascontiguousarray(p[:, 2]),
                    sigma_x=nan, sigma_y=nan, sigma_z=nan,
                    reprojection_error=nan.astype(np.float32))
        msgs.append((topics.MARKER_POINTS, 'dempath_msgs/msg/MarkerPoints3D', ns + 1, msg))
    bag = write_bag(tmp_path / 'measured', msgs, typestore=store)
    out = tmp_path / 'out'
    argv = ['--measured', str(bag), '--force', str(force), '--scene', SCENE, '--out', str(out),
            '--library-root', str(cache / 'library'), '--packing-cache', str(cache / 'packings'),
            '--seeds', ','.join(map(str, SPEC.seeds)), '--candidates', ','.join(SPEC.candidates),
            '--strengths', str(SPEC.n_strengths), '--serial']
    assert diagnose_main(argv) == 0
    data = json.loads((out / 'diagnosis.json').read_text())
    assert data['verdict'] == 'parameter_off' and data['ranking'][0]['effect'] == 'tool_speed'


def test_held_out_markers_are_checked(cache: Path, tiny_library: Library) -> None:
    """A bad ``held_out`` parameter is one error naming it; a held-out marker never received
    fails the pass's diagnosis with one error naming it (and the next pass can go on)."""
    import pytest

    from dempath_diagnose.decision.live import build_live, held_out_markers
    from dempath_diagnose.errors import MeasurementError

    assert held_out_markers('') == () and held_out_markers('3, 8,13') == (3, 8, 13)
    for bad in ('3;8', 'three', '3,3', '0'):
        with pytest.raises(MeasurementError, match='held_out'):
            held_out_markers(bad)
    markers, _ = case_files(cache, 'tool_speed')
    meas = load_tracks(markers)
    live = build_live(SCENE, tiny_library.folder, held_out=(999,))
    for i, t in enumerate(meas.times[::4]):
        live.add_markers(float(t), meas.markers, meas.positions[4 * i])
    with pytest.raises(MeasurementError, match=r'held_out 999: marker\(s\) \[999\] not received'):
        live.finish()
    assert not live.frames  # the next pass starts empty
