"""`dempath simulate`: outputs of a tiny run, and one error line for each bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dempath_sim.cli import simulate_main
from dempath_sim.runs.results import SimResult


def test_simulate_writes_outputs(tmp_path: Path, tmp_path_factory: pytest.TempPathFactory,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    """A tiny run writes the CSVs, the npz and a summary that agree with each other."""
    out = tmp_path / 'out'
    cache = Path(tmp_path_factory.getbasetemp()) / 'packings'
    code = simulate_main(['tiny', '--out', str(out), '--cache-dir', str(cache), '--quiet',
                          '--effect', 'tool_friction.static_friction=0.5', '--vtk'])
    assert code == 0, capsys.readouterr().err
    for name in ('model.csv', 'markers.csv', 'tool.csv', 'result.npz', 'summary.json'):
        assert (out / name).is_file(), name
    summary = json.loads((out / 'summary.json').read_text())
    result = SimResult.load_npz(out / 'result.npz')
    assert summary['effects']['tool_friction']['static_friction'] == 0.5
    assert summary['max_draft_force_n'] == pytest.approx(float(result.draft_force().max()))
    markers = np.loadtxt(out / 'markers.csv', delimiter=',', skiprows=1)
    assert set(markers[:, 1].astype(int)) == set(range(1, 16))
    assert 'particles' in capsys.readouterr().out
    _check_vtk(out / 'vtk', result)


def _check_vtk(folder: Path, result: SimResult) -> None:
    """The VTK series holds every snapshot's bed with its radii and the tool where it was."""
    import xml.etree.ElementTree as ET

    import meshio

    from dempath_sim.engine import TriangleMesh
    from dempath_sim.runs.vtk import tool_position_at
    from dempath_sim.scene import resolve_scene

    steps = ET.parse(folder / 'bed.pvd').getroot().findall('./Collection/DataSet')
    assert len(result.snapshot_times) >= 2
    assert [float(s.get('timestep', 'nan')) for s in steps] == pytest.approx(
        result.snapshot_times.tolist())
    last = len(steps) - 1
    bed = meshio.read(folder / steps[last].get('file', ''))
    snap = result.snapshot_positions[last].astype(np.float64)
    keep = np.isfinite(snap).all(axis=1)
    assert len(result.snapshot_radii) == len(result.snapshot_ids) > 0
    np.testing.assert_allclose(bed.points, snap[keep], rtol=1e-6)
    np.testing.assert_allclose(bed.point_data['radius'], result.snapshot_radii[keep])
    np.testing.assert_array_equal(bed.point_data['id'], result.snapshot_ids[keep])
    scene = resolve_scene('tiny')
    tris = TriangleMesh.from_stl(scene.tool.mesh, scale=scene.tool.scale).triangles
    tool = meshio.read(folder / f'tool_{last:04d}.vtu')
    at = tool_position_at(result, result.snapshot_times[last:])[0]
    np.testing.assert_allclose(tool.points, tris.reshape(-1, 3) + at, atol=1e-9)
    assert tool.cells_dict['triangle'].shape == (len(tris), 3)
    assert at[2] > result.tool_position[0, 2] + 0.01  # the tool has moved along Z


@pytest.mark.parametrize(('argv', 'needle'), [
    (['no_such_scene'], 'neither a scene file'),
    (['tiny', '--effect', 'cohesion.energy_density_j_m3=lots'], 'EFFECT.PARAMETER=NUMBER'),
    (['tiny', '--effect', 'cohesion.energy_density_j_m3=1e9'], 'out of range'),
    (['tiny', '--off', 'restitution'], 'cannot be switched off'),
    (['tiny', '--off', 'gravity'], 'unknown key'),
])
def test_simulate_bad_input(argv: list[str], needle: str, tmp_path: Path,
                            capsys: pytest.CaptureFixture[str]) -> None:
    """Each bad input gives exit code 1 and one `error:` line naming the problem."""
    assert simulate_main([*argv, '--out', str(tmp_path), '--quiet']) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('error: ') and needle in err[0]


def test_progress_bar_shows_sim_time_and_rtf() -> None:
    """The progress callback fills one task per phase with sim time and real-time factor."""
    from dempath_sim.cli import _progress_bar
    from dempath_sim.runs import Progress

    bar, update = _progress_bar(quiet=False)
    update(Progress('fill', 0.1, 0.5, 2.0))
    update(Progress('drive', 0.3, 0.6, 0.6))
    tasks = {t.description: t for t in bar.tasks}
    assert tasks['drive'].fields['sim'] == '0.300/0.600 s'
    assert tasks['drive'].fields['rtf'] == '0.5' and tasks['fill'].completed == 0.1
    assert _progress_bar(quiet=True) == (None, None)
