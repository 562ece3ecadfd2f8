"""Foreign model exports: a LIGGGHTS dump and a mapped Z-up CSV read as dempath's own CSV."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dempath_compare.errors import InputError
from dempath_compare.foreign import ExportMapping, load_mapping
from dempath_compare.loaders import load_source, read_csv_columns
from dempath_compare.pipeline import compare_paths
from dempath_compare.records import MODEL, Track

DT = 1e-5  # the dump's time step [s]
START_STEP = 4000  # the tool starts at this step of the dump


def _without_marker(example_dir: Path, tmp_path: Path) -> Path:
    """The example model CSV without its marker column (foreign exports do not have one)."""
    cols = read_csv_columns(example_dir / 'model_1ms.csv')
    out = tmp_path / 'model_1ms.csv'
    rows = np.column_stack([cols['t'], cols['id'], cols['x'], cols['y'], cols['z']])
    np.savetxt(out, rows, delimiter=',', header='t,id,x,y,z', comments='', fmt='%.9g')
    return out


def _write_dump(example_dir: Path, path: Path) -> None:
    """The example model as a ``dump custom`` file: one frame per time, extra columns."""
    cols = read_csv_columns(example_dir / 'model_1ms.csv')
    lines = []
    for t in np.unique(cols['t']):
        rows = np.flatnonzero(cols['t'] == t)
        lines += ['ITEM: TIMESTEP', str(round(t / DT) + START_STEP), 'ITEM: NUMBER OF ATOMS',
                  str(len(rows)), 'ITEM: BOX BOUNDS ff ff ff', '-1 1', '-1 1', '-1 1',
                  'ITEM: ATOMS id type x y z vx vy vz radius']
        lines += [f'{int(cols["id"][r])} 1 {cols["x"][r]:.9g} {cols["y"][r]:.9g} '
                  f'{cols["z"][r]:.9g} 0 0 0 0.004' for r in rows[::-1]]
    path.write_text('\n'.join(lines) + '\n')


def _same_tracks(got: list[Track], want: list[Track]) -> None:
    by_id = {t.ident: t for t in want}
    assert sorted(t.ident for t in got) == sorted(by_id)
    for track in got:
        ref = by_id[track.ident]
        np.testing.assert_allclose(track.times, ref.times, atol=1e-9)
        np.testing.assert_allclose(track.positions, ref.positions, atol=1e-8)


def test_liggghts_dump_reads_as_the_csv(example_dir: Path, tmp_path: Path) -> None:
    """A dump with step numbers and extra columns gives the CSV's tracks and the same scores."""
    plain = _without_marker(example_dir, tmp_path)
    dump = tmp_path / 'run.dump'
    _write_dump(example_dir, dump)
    mapping = ExportMapping(format='liggghts', dt_s=DT, start_step=START_STEP)
    _same_tracks(load_source(dump, MODEL, mapping), load_source(plain, MODEL))
    measured = example_dir / 'experiment_1ms.csv'
    a = compare_paths(measured, dump, model_map=mapping)
    b = compare_paths(measured, plain)
    np.testing.assert_allclose(a.scores.s_sum, b.scores.s_sum, rtol=1e-9)


def test_mapped_zup_csv_in_mm(example_dir: Path, tmp_path: Path) -> None:
    """A Z-up export in mm and ms, tool along -x, shifted origin, text columns: same tracks."""
    cols = read_csv_columns(example_dir / 'model_1ms.csv')
    origin = np.array([0.01, -0.02, 0.3])  # paper axes [m]
    paper = np.column_stack([cols['x'], cols['y'], cols['z']]) + origin
    # paper X = source y, paper Y = source z, paper Z = -source x
    source = np.column_stack([-paper[:, 2], paper[:, 0], paper[:, 1]]) * 1e3
    out = tmp_path / 'edem.csv'
    with out.open('w') as f:
        f.write('Time (ms),ID,Type,Position X,Position Y,Position Z\n')
        for k in range(len(cols['t'])):
            f.write(f'{(cols["t"][k] + 0.25) * 1e3:.9g},{int(cols["id"][k])},sand,'
                    f'{source[k, 0]:.9g},{source[k, 1]:.9g},{source[k, 2]:.9g}\n')
    map_file = tmp_path / 'edem.yaml'
    map_file.write_text(
        "format: csv\ncolumns: {t: 'Time (ms)', id: ID, x: 'Position X', y: 'Position Y', "
        "z: 'Position Z'}\nlength_unit: mm\ntime_unit: ms\naxes: [y, z, -x]\n"
        f'origin: {origin.tolist()}\ntool_start_s: 0.25\n')
    mapping = load_mapping(map_file)
    _same_tracks(load_source(out, MODEL, mapping),
                 load_source(_without_marker(example_dir, tmp_path), MODEL))


@pytest.mark.parametrize(('text', 'problem'), [
    ('axes: [x, x, z]\n', 'axes'),
    ('length_unit: inch\n', 'length_unit'),
    ('format: liggghts\n', 'dt_s'),
    ('colour: red\n', 'unknown'),
])
def test_bad_model_map_names_the_field(tmp_path: Path, text: str, problem: str) -> None:
    """A wrong model map is refused with the file and the field named."""
    path = tmp_path / 'map.yaml'
    path.write_text(text)
    with pytest.raises(InputError, match=rf'map\.yaml: model map: .*{problem}'):
        load_mapping(path)


def test_cli_dump_without_map_is_one_line(example_dir: Path, tmp_path: Path) -> None:
    """``dempath compare`` on a dump without a model map: one error line, exit 1."""
    dump = tmp_path / 'run.dump'
    _write_dump(example_dir, dump)
    proc = subprocess.run(
        [sys.executable, '-m', 'dempath_compare.cli', str(example_dir / 'experiment_1ms.csv'),
         str(dump), '--out', str(tmp_path / 'out'), '--no-plots'],
        capture_output=True, text=True, check=False)
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr.strip().splitlines() == [
        f'error: {dump}: a LIGGGHTS dump; give a model map (--model-map) with format: liggghts '
        'and its time step dt_s']
