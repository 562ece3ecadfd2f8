"""Bad inputs: each gives one clear line naming the input, per-marker faults leave the rest."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath_diagnose.cli import diagnose_main
from dempath_diagnose.decision.measure import check_force_scale, load_force, load_tracks
from dempath_diagnose.errors import ClusterError, MeasurementError
from dempath_diagnose.library.sweep import DaskSweep


def write_markers(path: Path, rows: list[tuple[float, int, float, float, float]]) -> Path:
    """CSV t,marker,x,y,z."""
    path.write_text('t,marker,x,y,z\n' + ''.join(f'{t},{m},{x},{y},{z}\n'
                                                  for t, m, x, y, z in rows))
    return path


def moving(marker: int, n: int = 20, scale: float = 1.0, dt: float = 0.02,
           ) -> list[tuple[float, int, float, float, float]]:
    """A marker moving 40 mm forward (scale 1000: the same in millimetres)."""
    return [(i * dt, marker, 0.05 * scale, 0.0, (0.1 + 0.002 * i) * scale) for i in range(n)]


def test_per_marker_faults_are_reported_and_the_rest_kept(tmp_path: Path) -> None:
    """NaN samples dropped; < 3 points, no motion, duplicated stamps: that marker left out."""
    rows = moving(1) + moving(2)[:2] + [(i * 0.02, 3, 0.0, 0.0, 0.1) for i in range(20)]
    rows += [(0.0, 4, 0.0, 0.0, 0.1), (0.0, 4, 0.0, 0.0, 0.11), (0.02, 4, 0.0, 0.0, 0.12)]
    rows += [(t, 5, float('nan') if k == 3 else x, y, z)
             for k, (t, _, x, y, z) in enumerate(moving(5))]
    rows += [r for k, r in enumerate(moving(6)) if k % 3]  # missing from some frames
    meas = load_tracks(write_markers(tmp_path / 'm.csv', rows))
    assert sorted(meas.markers.tolist()) == [1, 5, 6]
    assert 'fewer than 3' in meas.problems[2]
    assert meas.problems[3] == 'no motion'
    assert meas.problems[4] == 'duplicated time stamps'
    assert np.all(np.isfinite(meas.positions[meas.times >= 0.02]))  # marker 6 unseen at t = 0


def test_millimetres_are_one_clear_error(tmp_path: Path) -> None:
    """A 40 m displacement (millimetres given as metres): one error naming the file."""
    path = write_markers(tmp_path / 'mm.csv', moving(1, scale=1000.0))
    with pytest.raises(MeasurementError, match='look like millimetres'):
        load_tracks(path)


def test_no_usable_marker(tmp_path: Path) -> None:
    """Every marker faulty: one error naming the file and the faults."""
    path = write_markers(tmp_path / 'bad.csv', moving(1)[:2])
    with pytest.raises(MeasurementError, match='no usable marker'):
        load_tracks(path)


def test_force_sign_and_unit(tmp_path: Path) -> None:
    """The force of the tool on the particles (draft < 0) and a force in kN are refused."""
    path = tmp_path / 'f.csv'
    path.write_text('t,Fx,Fy,Fz\n' + ''.join(f'{i * 0.01},0,0,{2.0 + i}\n' for i in range(10)))
    with pytest.raises(MeasurementError, match='wrong sign convention'):
        load_force(path)
    path.write_text('t,Fx,Fy,Fz\n' + ''.join(f'{i * 0.01},0,0,{-2.0 - i}\n' for i in range(10)))
    t, f = load_force(path)
    assert len(t) == 10 and f[0, 2] == -2.0
    with pytest.raises(MeasurementError, match='another unit'):
        check_force_scale(path, 0.004, 5.0)


def test_cli_bad_inputs_give_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Bad origin, missing file, too long a window: exit 1 with one 'error:' line each."""
    good = write_markers(tmp_path / 'm.csv', moving(1))
    long = write_markers(tmp_path / 'long.csv', moving(1, n=40, dt=0.5))
    cases = [(['--measured', str(good), '--origin', '1,2'], '--origin'),
             (['--measured', str(tmp_path / 'nope.csv')], 'nope.csv'),
             (['--measured', str(long)], 'longer than the model can run')]
    for argv, expected in cases:
        code = diagnose_main([*argv, '--scene', 'builtin:tiny', '--out', str(tmp_path / 'o')])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 1
        assert len(err) == 1 and err[0].startswith('error: ') and expected in err[0], err


def test_unreachable_scheduler_is_one_clear_error() -> None:
    """A scheduler address nobody listens on: ClusterError naming the address."""
    with pytest.raises(ClusterError, match=r'tcp://127\.0\.0\.1:9'), \
            DaskSweep('tcp://127.0.0.1:9', timeout_s=2.0) as sweep:
        sweep.run([], lambda k, v: None)


def test_cli_force_in_kilonewtons_and_faulty_markers(cache: Path, tiny_library: object,
                                                     tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    """A tiny-scene case with three faulty markers added (NaN rows, two points, no motion): they
    are warned about, reported in diagnosis.json and the rest is diagnosed; the same case with
    its force in kN is one error line naming the force file, and the first output is kept."""
    import json

    from .conftest import SCENE, SPEC
    from .test_hidden import case_files

    markers, force = case_files(cache, 'tool_speed')
    bad = tmp_path / 'markers.csv'
    rows = [(i * 0.02, 90, float('nan'), 0.0, 0.1) for i in range(5)]
    rows += [(0.0, 91, 0.0, 0.03, 0.1), (0.02, 91, 0.0, 0.03, 0.11)]
    rows += [(i * 0.02, 92, 0.0, 0.03, 0.12) for i in range(20)]
    bad.write_text(markers.read_text() + ''.join(f'{t},{m},{x},{y},{z}\n'
                                                 for t, m, x, y, z in rows))
    common = ['--scene', SCENE, '--library-root', str(cache / 'library'), '--packing-cache',
              str(cache / 'packings'), '--seeds', ','.join(map(str, SPEC.seeds)),
              '--candidates', ','.join(SPEC.candidates), '--strengths', str(SPEC.n_strengths),
              '--serial']
    out = tmp_path / 'out'
    assert diagnose_main(['--measured', str(bad), '--force', str(force), '--out', str(out),
                          *common]) == 0
    err = capsys.readouterr().err
    for m in (90, 91, 92):
        assert f'marker {m}:' in err, err
    data = json.loads((out / 'diagnosis.json').read_text())
    assert set(data['marker_problems']) == {'90', '91', '92'}
    assert data['verdict'] == 'parameter_off' and data['ranking'][0]['effect'] == 'tool_speed'
    kilo = tmp_path / 'force_kN.csv'
    lines = force.read_text().splitlines()
    kilo.write_text('\n'.join([lines[0]] + [','.join([r.split(',')[0]] + [
        f'{float(v) / 1000:.6g}' for v in r.split(',')[1:]]) for r in lines[1:]]) + '\n')
    before = (out / 'diagnosis.json').read_text()
    assert diagnose_main(['--measured', str(markers), '--force', str(kilo), '--out', str(out),
                          *common]) == 1
    err_lines = capsys.readouterr().err.strip().splitlines()
    assert len(err_lines) == 1 and 'force_kN.csv' in err_lines[0], err_lines
    assert 'another unit' in err_lines[0]
    assert (out / 'diagnosis.json').read_text() == before  # nothing already written is lost
