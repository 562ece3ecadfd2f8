"""`--backend liggghts`: a library run on LIGGGHTS 3.8 from dempath's settled bed of the seed;
`--model`: Table 7 against a user's own LIGGGHTS run."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dempath.nodes.pytest_plugin import require_component
from dempath_diagnose.cli import diagnose_main
from dempath_diagnose.decision.bandtracks import band_table7
from dempath_diagnose.decision.diagnosis import CaseGeometry
from dempath_diagnose.decision.measure import load_tracks
from dempath_diagnose.library.simulator import load_scene, pass_travel_s, run_pass
from dempath_diagnose.library.store import Library, LibrarySpec, library_dir

from .conftest import SCENE
from .test_hidden import case_files


@pytest.mark.timeout(1200)  # a guard, not a timing: one LIGGGHTS pass of the tiny scene
def test_liggghts_run_is_a_library_record(cache: Path, tmp_path: Path) -> None:
    """The pass covers the library's window, keeps the near-surface particles of the same bed
    (LIGGGHTS ids = dempath's + 1), the tool stands still after its travel, the draft is
    positive; the LIGGGHTS library has its own folder."""
    from dempath_sim.liggghts.errors import LiggghtsNotFoundError
    from dempath_sim.liggghts.install import ensure_liggghts

    try:
        ensure_liggghts(install=True)  # apt-get under the install lock, as dempath_sim's tests
    except LiggghtsNotFoundError as err:
        require_component('liggghts', err)  # fails unless skipped on purpose
    scene = load_scene(SCENE)
    until = round(pass_travel_s(scene, {}) + 0.1, 6)
    packings = cache / 'packings'
    ours = run_pass(scene, 1001, {}, until_s=until, cache_dir=packings)
    theirs = run_pass(scene, 1001, {}, until_s=until, cache_dir=packings, backend='liggghts')
    assert theirs.times[-1] >= until - 0.03
    assert len(set(theirs.ids.tolist()) & set((ours.ids + 1).tolist())) >= 0.9 * len(ours.ids)
    stop = theirs.meta['tool_stop_s']
    after = theirs.times > stop + 0.02
    assert after.any()
    assert float(np.ptp(theirs.tool_position[after], axis=0).max()) < 1e-6
    moving = theirs.force_times < stop
    assert float(np.mean(-theirs.tool_force[moving, 2])) > 0
    spec = LibrarySpec()
    assert library_dir(scene, spec, tmp_path, 'liggghts') != library_dir(scene, spec, tmp_path)


def test_table7_against_a_users_own_liggghts_dump(cache: Path, tiny_library: Library,
                                                  geometry: CaseGeometry,
                                                  tmp_path: Path) -> None:
    """``--model DUMP --model-map``: Table 7 of the user's own run (here a library run written
    as a LIGGGHTS dump) equals Table 7 of that run read directly."""
    markers, force = case_files(cache, 'cohesion')
    name = 'baseline-s1001.npz'
    record = tiny_library.records[name]
    dt = 1e-4
    lines = []
    for k, t in enumerate(record.times):
        ok = np.isfinite(record.positions[k]).all(1)
        lines += ['ITEM: TIMESTEP', str(round(t / dt)), 'ITEM: NUMBER OF ATOMS',
                  str(int(ok.sum())), 'ITEM: BOX BOUNDS ff ff ff', '-1 1', '-1 1', '-1 1',
                  'ITEM: ATOMS id type x y z']
        lines += [f'{i} 1 {p[0]:.9g} {p[1]:.9g} {p[2]:.9g}'
                  for i, p in zip(record.ids[ok], record.positions[k][ok], strict=True)]
    dump = tmp_path / 'mine.dump'
    dump.write_text('\n'.join(lines) + '\n')
    model_map = tmp_path / 'map.yaml'
    model_map.write_text(f'format: liggghts\ndt_s: {dt}\n')
    out = tmp_path / 'diag'
    assert diagnose_main(['--measured', str(markers), '--force', str(force), '--scene', SCENE,
                          '--out', str(out), '--library', str(tiny_library.folder),
                          '--model', str(dump), '--model-map', str(model_map),
                          '--serial']) == 0
    table = json.loads((out / 'diagnosis.json').read_text())['error_before']['table7']
    want = band_table7(load_tracks(markers), [record], geometry.cube_m, ['run'])
    assert table['model'] == str(dump) and len(table['rows']) == len(want['rows']) >= 10
    for got, ref in zip(table['rows'], want['rows'], strict=True):
        assert got['marker'] == ref['marker']
        assert abs(got['mae_m'] - ref['mae_m']) < 1e-6 and got['n_best'] == ref['n_best']
    assert 'your model run' in (out / 'report.md').read_text()
