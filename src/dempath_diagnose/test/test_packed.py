"""A library packed into one file for a marker region diagnoses exactly as its folder does."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dempath_diagnose.cli import diagnose_main
from dempath_diagnose.decision.diagnosis import CaseGeometry, diagnose
from dempath_diagnose.decision.measure import load_force, load_tracks
from dempath_diagnose.library.packed import QUANTUM_M, export_library
from dempath_diagnose.library.store import Library

from .conftest import SCENE
from .test_hidden import case_files


def folder_bytes(folder: Path) -> int:
    """Bytes of every file under ``folder``."""
    return sum(p.stat().st_size for p in folder.rglob('*') if p.is_file())


def test_packed_library_gives_the_same_diagnosis(cache: Path, tiny_library: Library,
                                                 geometry: CaseGeometry, tmp_path: Path) -> None:
    """Tool-speed case: same verdict, ranking, probabilities, strengths and Table 7 from the
    packed file as from the folder; the file is a fraction of the folder; positions within
    half a quantum."""
    markers, force = case_files(cache, 'tool_speed')
    meas = load_tracks(markers)
    t, f = load_force(force)
    meas = replace(meas, force_times=t, force=f)
    path = tmp_path / 'tiny.npz'
    summary = export_library(tiny_library, path, geometry.cube_m, meas.start)
    assert summary['bytes'] < folder_bytes(tiny_library.folder) / 3, summary
    packed = Library.load(path)
    assert [r.filename for r in packed.runs] == [r.filename for r in tiny_library.runs]
    for name, rec in packed.records.items():
        full = tiny_library.records[name]
        at = np.searchsorted(full.ids, rec.ids)
        assert np.array_equal(full.ids[at], rec.ids)
        diff = np.abs(rec.positions - full.positions[:, at])
        assert np.nanmax(diff) <= QUANTUM_M * 0.51 + 1e-6
        assert np.array_equal(np.isnan(rec.positions), np.isnan(full.positions[:, at]))
    a = diagnose(meas, tiny_library, geometry)
    b = diagnose(meas, packed, geometry)
    assert a.decision.verdict == b.decision.verdict == 'parameter_off'
    assert [x.name for x in a.decision.ranking] == [x.name for x in b.decision.ranking]
    for x, y in zip([a.decision.baseline, *a.decision.ranking],
                    [b.decision.baseline, *b.decision.ranking], strict=True):
        assert abs(x.probability - y.probability) < 0.01, (x.name, x.probability, y.probability)
        assert abs(x.implausibility - y.implausibility) < 0.05
    top_a, top_b = a.decision.ranking[0], b.decision.ranking[0]
    assert abs(top_a.strength - top_b.strength) < 0.1 * top_a.strength_sd + 1e-3
    assert np.allclose(a.measured, b.measured)
    assert np.allclose(a.emulator.mu0, b.emulator.mu0, atol=1e-4)
    assert abs(a.table7['mean_nrmse_pct'] - b.table7['mean_nrmse_pct']) < 0.5


def test_cli_exports_and_diagnoses_from_the_file(cache: Path, tiny_library: Library,
                                                 tmp_path: Path) -> None:
    """--export-library writes the file; --library FILE diagnoses from it (no build); a marker
    starting outside the packed region is reported and left out, the rest diagnosed."""
    from .conftest import SPEC

    markers, force = case_files(cache, 'tool_speed')
    packed = tmp_path / 'lib.npz'
    common = ['--scene', SCENE, '--library-root', str(cache / 'library'), '--packing-cache',
              str(cache / 'packings'), '--seeds', ','.join(map(str, SPEC.seeds)),
              '--candidates', ','.join(SPEC.candidates), '--strengths', str(SPEC.n_strengths),
              '--serial']
    assert diagnose_main(['--measured', str(markers), '--force', str(force), '--out',
                          str(tmp_path / 'a'), '--export-library', str(packed), *common]) == 0
    a = json.loads((tmp_path / 'a' / 'diagnosis.json').read_text())
    assert a['exported_library']['bytes'] == packed.stat().st_size
    moved = tmp_path / 'moved.csv'  # marker 1 starts 50 mm back (still in the bin): outside
    lines = markers.read_text().splitlines()  # the packed region
    out = [lines[0]]
    for line in lines[1:]:
        t, m, x, y, z = line.split(',')
        out.append(f'{t},{m},{x},{y},{float(z) - 0.05 if m == "1" else z}')
    moved.write_text('\n'.join(out) + '\n')
    assert diagnose_main(['--measured', str(moved), '--force', str(force), '--out',
                          str(tmp_path / 'b'), '--library', str(packed), *common]) == 0
    b = json.loads((tmp_path / 'b' / 'diagnosis.json').read_text())
    assert b['library'] == str(packed)
    assert 'outside the packed' in b['marker_problems']['1']
    assert b['verdict'] == a['verdict'] == 'parameter_off'
    assert b['ranking'][0]['effect'] == 'tool_speed'


def test_export_needs_a_region(tiny_library: Library, geometry: CaseGeometry,
                               tmp_path: Path) -> None:
    """Neither marker starts nor a box: one clear error naming the file."""
    from dempath_diagnose.errors import LibraryError

    with pytest.raises(LibraryError, match='give the marker starts or a box'):
        export_library(tiny_library, tmp_path / 'x.npz', geometry.cube_m)
    box = np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])
    summary = export_library(tiny_library, tmp_path / 'all.npz', geometry.cube_m, box=box)
    sizes = [len(rec.ids) for rec in tiny_library.records.values()]
    assert (summary['particles_min'], summary['particles_max']) == (min(sizes), max(sizes))
