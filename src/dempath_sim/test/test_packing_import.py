"""A scene's own packing (LIGGGHTS data, CSV, npz) and the fill's bulk density target."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dempath_sim.errors import SceneError
from dempath_sim.runs.bed import fill_bed
from dempath_sim.runs.physics import build_params
from dempath_sim.scene import bundled_scene
from dempath_sim.scene.loader import SCENES_DIR
from dempath_sim.scene.spec import SceneSpec


def cubic_bed(scene: SceneSpec, d: float = 0.012) -> tuple[np.ndarray, np.ndarray]:
    """A simple-cubic bed of touching spheres filling the tiny bin's floor (4 layers)."""
    half, length, floor = scene.bin.width_x_m / 2, scene.bin.length_z_m, -scene.bed_thickness_m
    axes = [np.arange(-half + d / 2, half - d / 2 + 1e-9, d),
            floor + d / 2 + d * np.arange(4), np.arange(d / 2, length - d / 2 + 1e-9, d)]
    pos = np.stack(np.meshgrid(*axes, indexing='ij'), axis=-1).reshape(-1, 3)
    return pos, np.full(len(pos), d)


def write(path: Path, pos: np.ndarray, d: np.ndarray) -> Path:
    """The bed as a LIGGGHTS data file, a CSV or an npz, chosen by the suffix."""
    if path.suffix == '.npz':
        np.savez(path, positions=pos, diameters=d)
    elif path.suffix == '.csv':
        rows = '\n'.join(','.join(repr(float(v)) for v in (*p, s))
                         for p, s in zip(pos, d, strict=True))
        path.write_text('x,y,z,d\n' + rows + '\n')
    else:
        head = ['LIGGGHTS data file', '', f'{len(pos)} atoms', '3 atom types',
                '-1 1 xlo xhi', '-1 1 ylo yhi', '-1 1 zlo zhi', '', 'Atoms # granular', '']
        rows = [f'{k + 1} 1 {float(s)!r} 1734 ' + ' '.join(repr(float(v)) for v in p)
                for k, (p, s) in enumerate(zip(pos, d, strict=True))]
        path.write_text('\n'.join(head + rows) + '\n')
    return path


def with_packing(scene: SceneSpec, path: Path) -> SceneSpec:
    """The scene with ``fill.packing`` set."""
    return replace(scene, fill=replace(scene.fill, packing=path))


@pytest.mark.parametrize('name', ['bed.data', 'bed.csv', 'bed.npz'])
def test_packing_round_trip(tmp_path: Path, name: str) -> None:
    """Each format gives back the same spheres, measured as the bed (no pour, no cache)."""
    scene = bundled_scene('tiny')
    pos, d = cubic_bed(scene)
    scene = with_packing(scene, write(tmp_path / name, pos, d))
    model = scene.bed_model()
    state, report = fill_bed(scene, model, build_params(scene, model), tmp_path / 'cache')
    np.testing.assert_allclose(state.positions, pos, rtol=0, atol=1e-12)
    np.testing.assert_allclose(2 * state.radii, d)
    assert report.source == str(tmp_path / name) and report.key.startswith('file:')
    assert report.surface_height_m == pytest.approx(-scene.bed_thickness_m + 4 * 0.012)
    assert not (tmp_path / 'cache').exists()


@pytest.mark.parametrize(('change', 'message'), [
    (lambda p, d: (np.vstack([p, p[:1] + np.array([0.003, 0.0, 0.0])]), np.append(d, d[0])),
     r'overlap by 150\.0 % of the smaller radius'),
    (lambda p, d: (p + np.array([0.0, 0.0, 0.05]), d), 'particles lie outside the bin'),
    (lambda p, d: (p * 1000, d * 1000), 'looks like millimetres'),
])
def test_bad_packing_is_one_error_naming_the_file(tmp_path: Path, change, message) -> None:
    """Overlaps, spheres outside the bin and millimetres: one SceneError naming the file."""
    scene = bundled_scene('tiny')
    pos, d = change(*cubic_bed(scene))
    path = write(tmp_path / 'bed.csv', pos, d)
    scene = with_packing(scene, path)
    model = scene.bed_model()
    with pytest.raises(SceneError, match=f'^{path}: .*{message}'):
        fill_bed(scene, model, build_params(scene, model), tmp_path / 'cache')


def test_cli_bad_packing_writes_nothing(tmp_path: Path) -> None:
    """`dempath simulate` on a scene with a millimetre packing: one error line, no output."""
    scene = bundled_scene('tiny')
    pos, d = cubic_bed(scene)
    write(tmp_path / 'bed_mm.csv', pos * 1000, d * 1000)
    text = (SCENES_DIR / 'tiny.yaml').read_text().replace(
        'builtin:chisel.stl', str(SCENES_DIR.parent / 'chisel.stl'))
    text = text.replace('fill: {', 'fill: {packing: bed_mm.csv, ')
    (tmp_path / 'scene.yaml').write_text(text)
    out = tmp_path / 'run'
    done = subprocess.run([sys.executable, '-m', 'dempath.cli', 'simulate',
                           str(tmp_path / 'scene.yaml'), '--out', str(out)],
                          capture_output=True, text=True, check=False)
    lines = [x for x in done.stderr.splitlines() if x.startswith('error:')]
    assert done.returncode == 1 and len(lines) == 1 and 'bed_mm.csv' in lines[0]
    assert 'millimetres' in lines[0] and not (out.exists() and any(out.iterdir()))


def test_fill_reaches_the_target_within_tolerance(tmp_path: Path) -> None:
    """The tiny bed is compacted to a requested bulk density within the default 2 %."""
    scene = bundled_scene('tiny')
    scene = replace(scene, fill=replace(scene.fill, bulk_density_target_kg_m3=1050.0))
    model = scene.bed_model()
    _, report = fill_bed(scene, model, build_params(scene, model), tmp_path)
    assert scene.fill.tolerance == 0.02 and report.within_tolerance
    assert report.bulk_density_kg_m3 == pytest.approx(1050.0, rel=0.02)
    assert report.target_solid_fraction == pytest.approx(1050.0 / 1734)


def test_unreachable_targets_are_one_error(tmp_path: Path) -> None:
    """Too dense is refused before pouring; too loose after the pour, naming what it reached."""
    scene = bundled_scene('tiny')
    dense = replace(scene, fill=replace(scene.fill, bulk_density_target_kg_m3=1300.0))
    model = dense.bed_model()
    with pytest.raises(SceneError, match=r'1300 kg/m\^3 needs a solid fraction 0\.750'):
        fill_bed(dense, model, build_params(dense, model), tmp_path)
    loose = replace(scene, fill=replace(scene.fill, bulk_density_target_kg_m3=600.0))
    with pytest.raises(SceneError, match=r'600 kg/m\^3 cannot be reached within 2 %: the loosest'):
        fill_bed(loose, model, build_params(loose, model), tmp_path)
    assert not list(tmp_path.glob('*.npz'))
