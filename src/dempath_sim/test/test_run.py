"""End-to-end runs of the tiny scene: kinematics, recording, CSV/npz export, determinism."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath_sim.runs import (
    ROLE_MARKER,
    Frame,
    NativeBackend,
    RunOptions,
    SimResult,
    Variant,
    run_batch,
    run_scene,
)
from dempath_sim.scene import bundled_scene
from dempath_sim.scene.profiles import ToolPath


def cache_dir(factory: pytest.TempPathFactory) -> Path:
    """The packing cache shared by the tests of one session."""
    return Path(factory.getbasetemp()) / 'packings'


@pytest.fixture(scope='module')
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[SimResult, list[Frame]]:
    """One run of the tiny scene and the frames it streamed."""
    frames: list[Frame] = []
    options = RunOptions(cache_dir=cache_dir(tmp_path_factory), on_frame=frames.append)
    return run_scene(bundled_scene('tiny'), options), frames


def test_output_times_and_shapes(tiny_run: tuple[SimResult, list[Frame]]) -> None:
    """Frames every 0.01 s from 0 to the end of travel; arrays have the documented shapes."""
    result, frames = tiny_run
    nt, n = len(result.times), len(result.ids)
    np.testing.assert_allclose(np.diff(result.times), 0.01, rtol=0.05)
    assert result.times[-1] >= result.meta['end_time_s'] - 1e-9
    assert result.positions.shape == (nt, n, 3) and result.velocities.shape == (nt, n, 3)
    assert result.tool_force.shape == (nt, 3) and result.tool_torque.shape == (nt, 3)
    assert (result.roles == ROLE_MARKER).sum() == 15 and n > 15
    assert len(frames) == nt
    np.testing.assert_array_equal(frames[-1].positions, result.positions[-1])
    assert result.snapshot_positions.shape[1] == len(result.snapshot_ids) > n


def test_tool_follows_the_profile(tiny_run: tuple[SimResult, list[Frame]]) -> None:
    """The recorded tool tip follows the analytic path; depth below the settled surface."""
    result, _ = tiny_run
    scene = bundled_scene('tiny')
    surface = result.meta['fill']['surface_height_m']
    start = (0.0, surface - scene.tool.depth_m, scene.tool.start_z_m)
    path = ToolPath(scene.tool.profile, start)
    expected = np.array([path.pose_at(t)[0] for t in result.times])
    np.testing.assert_allclose(result.tool_position, expected, atol=1e-9)
    assert result.tool_position[-1, 2] - start[2] >= scene.tool.travel_m - 1e-9


def test_soil_resists_and_markers_move(tiny_run: tuple[SimResult, list[Frame]]) -> None:
    """The draft force is positive while cutting and the first axis marker is pushed."""
    result, _ = tiny_run
    late = result.times > 0.1
    assert result.draft_force()[late].mean() > 0.0
    track = result.marker_trajectory(1)
    moved = np.linalg.norm(track[-1] - track[0])
    assert moved > 0.005, moved
    lateral = result.marker_trajectory(15)
    assert np.linalg.norm(lateral[-1] - lateral[0]) < moved


def test_csv_and_npz_round_trip(tiny_run: tuple[SimResult, list[Frame]], tmp_path: Path) -> None:
    """CSV rows (t,id,marker,x,y,z) and (t,marker,x,y,z) and the npz give back the arrays."""
    result, _ = tiny_run
    result.write_model_csv(tmp_path / 'model.csv')
    result.write_marker_csv(tmp_path / 'markers.csv')
    model = np.loadtxt(tmp_path / 'model.csv', delimiter=',', skiprows=1)
    markers = np.loadtxt(tmp_path / 'markers.csv', delimiter=',', skiprows=1)
    assert (tmp_path / 'markers.csv').read_text().startswith('t,marker,x,y,z')
    first = markers[markers[:, 1] == 1]
    np.testing.assert_allclose(first[:, 2:], result.marker_trajectory(1), atol=1e-6)
    assert model.shape[0] == np.isfinite(result.positions[..., 0]).sum()
    result.save_npz(tmp_path / 'r.npz')
    back = SimResult.load_npz(tmp_path / 'r.npz')
    np.testing.assert_array_equal(back.positions, result.positions)
    assert back.meta['run_id'] == result.meta['run_id']


def test_deterministic_and_batch(tiny_run: tuple[SimResult, list[Frame]],
                                 tmp_path_factory: pytest.TempPathFactory) -> None:
    """The same scene and seed repeat exactly; a batch runs each variant on the backend."""
    result, _ = tiny_run
    variants = [Variant('base'), Variant('slick', off=('tool_friction',))]
    runs = run_batch(bundled_scene('tiny'), variants,
                     options=RunOptions(cache_dir=cache_dir(tmp_path_factory)),
                     backend=NativeBackend())
    assert [v.label for v, _, _ in runs] == ['base', 'slick']
    np.testing.assert_array_equal(runs[0][2].positions, result.positions)
    assert runs[1][2].meta['run_id'] != result.meta['run_id']
    assert runs[1][2].meta['fill']['from_cache']
    assert not np.array_equal(runs[1][2].tool_force, result.tool_force)
