"""Inputs checked against each other before a diagnosis (issue 27): the library's scene and
physics, the markers' place in the bin, the force file's time base, broken library files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath_diagnose.admission import (
    check_force_time_base,
    check_pass_times,
    markers_in_bin,
)
from dempath_diagnose.errors import LibraryError, MeasurementError
from dempath_diagnose.library.store import Library
from dempath_diagnose.records import Measurement
from dempath_sim.scene import bundled_scene

SHIPPED = (Path(__file__).resolve().parents[1] / 'dempath_diagnose' / 'data' / 'libraries'
           / 'reduced_1ms_library.npz')


@pytest.fixture(scope='module')
def shipped() -> Library:
    """The shipped packed library of reduced_1ms."""
    return Library.load(SHIPPED)


def test_shipped_library_carries_its_scene(shipped: Library) -> None:
    """The packed file names its scene and physics and is accepted for that scene."""
    assert shipped.identity['scene'] == 'reduced_1ms'
    shipped.check_scene(bundled_scene('reduced_1ms'))


def test_library_refused_for_another_scene(shipped: Library) -> None:
    """The reduced library for the tiny scene: one line naming both scenes and what differs
    (it used to give a full diagnosis and a recalibration at the range's edge)."""
    with pytest.raises(LibraryError) as err:
        shipped.check_scene(bundled_scene('tiny'))
    text = str(err.value)
    assert "for scene 'reduced_1ms'" in text and "not for 'tiny'" in text
    assert 'differ in bin, layers' in text and 'markers' in text and '\n' not in text


def test_library_refused_for_other_physics(shipped: Library) -> None:
    """A reduced_1ms with Young's modulus x3 is other physics: refused, naming the effects."""
    scene = bundled_scene('reduced_1ms')
    modulus = scene.effects['youngs_modulus'].values['youngs_modulus_pa']
    stiff = scene.with_overrides({'youngs_modulus.youngs_modulus_pa': 3.0 * modulus})
    with pytest.raises(LibraryError, match=r'differ in effects$'):
        shipped.check_scene(stiff)


def damaged_library(path: Path, damage: str) -> Path:
    """The shipped library written to ``path`` truncated, empty, of an older layout (no
    ``linked`` in its candidates) or without a run's array."""
    import json

    data = SHIPPED.read_bytes()
    if damage == 'truncated':
        path.write_bytes(data[:len(data) // 2])
    elif damage == 'empty':
        path.write_bytes(b'')
    else:
        with np.load(SHIPPED) as packed:
            arrays = {k: packed[k] for k in packed.files}
        design = json.loads(str(arrays['design']))
        if damage == 'older_layout':
            for c in design['candidates']:
                del c['linked']
        else:
            del arrays['r3_steps']
        arrays['design'] = np.array(json.dumps(design))
        np.savez(path, **arrays)
    return path


@pytest.mark.parametrize('damage', ['truncated', 'empty', 'older_layout', 'no_runs'])
def test_broken_library_file_is_one_line(tmp_path: Path, damage: str) -> None:
    """A truncated, empty or older-layout packed library: LibraryError naming the file
    (BadZipFile, EOFError and KeyError tracebacks before)."""
    path = damaged_library(tmp_path / 'lib.npz', damage)
    with pytest.raises(LibraryError) as err:
        Library.load(path)
    assert str(err.value).startswith(f'{path}: ') and '\n' not in str(err.value)


def measurement(starts: np.ndarray) -> Measurement:
    """Markers resting at ``starts`` (m, 3) for 0.6 s."""
    times = np.arange(0.0, 0.6001, 0.005)
    positions = np.repeat(starts[None], len(times), axis=0)
    return Measurement(np.arange(1, len(starts) + 1), times, positions)


def test_markers_outside_the_bin_are_refused_or_left_out() -> None:
    """The reduced scene's grid (Z 0.35-0.55 m) lies outside tiny's 0.22 m bin: refused. One
    marker of tiny's own grid 0.3 m off: left out and named, the rest kept."""
    grid = np.array([[0.05 * r, 0.0, 0.35 + 0.05 * c] for r in range(3) for c in range(5)])
    kept = markers_in_bin(Path('m.csv'), measurement(grid), bundled_scene('reduced_1ms'))
    assert len(kept.markers) == 15
    with pytest.raises(MeasurementError, match=r"15 of 15 markers start outside the bin of "
                                               r"scene 'tiny'"):
        markers_in_bin(Path('m.csv'), measurement(grid), bundled_scene('tiny'))
    small = np.array([[0.025 * r, 0.0, 0.08 + 0.025 * c] for r in range(3) for c in range(5)])
    small[0, 0] += 0.3
    kept = markers_in_bin(Path('m.csv'), measurement(small), bundled_scene('tiny'))
    assert kept.markers.tolist() == list(range(2, 16))
    assert kept.problems[1].startswith("starts outside the bin of scene 'tiny'")


MEAS_T = np.arange(0.0, 0.6001, 0.005)


@pytest.mark.parametrize(('times', 'needle'), [
    (np.arange(0.0, 0.6001, 0.001) * 1e3, 'milliseconds'),
    (1.7e9 + np.arange(0.0, 0.6001, 0.001), 'a clock time'),
    (np.arange(0.0, 0.05, 0.001), 'covers t = 0.000..0.049 s, 8% of the measured pass'),
    (np.arange(0.0, 0.6001, 0.001) - 5.0, 'before the pass start'),
])
def test_force_time_base_is_checked(times: np.ndarray, needle: str) -> None:
    """Force times in ms, as clock time, covering 0-0.05 s, or shifted by -5 s: refused (they
    used to move the fitted cohesion or turn the verdict inconclusive, exit 0)."""
    with pytest.raises(MeasurementError, match=needle):
        check_force_time_base(Path('force.csv'), times, MEAS_T)


def test_force_on_the_pass_time_is_accepted() -> None:
    """A force sampled at 1 kHz over the pass (and a little before and after) passes."""
    check_force_time_base(Path('force.csv'), np.arange(-0.1, 0.8, 0.001), MEAS_T)


def test_marker_times_before_the_pass_are_refused() -> None:
    """Marker times from -5 s to -4.4 s (an IndexError before): one line with the times."""
    with pytest.raises(MeasurementError, match=r't runs from -5.000 to -4.400 s'):
        check_pass_times(Path('m.csv'), -5.0, -4.4)
    check_pass_times(Path('m.csv'), -0.1, 0.6)


def test_library_folder_design_carries_the_identity(tmp_path: Path) -> None:
    """A library folder's design.json without the identity (an older build) is still compared
    by its scene name."""
    from dempath_diagnose.library.scene_identity import check_library_scene

    check_library_scene(tmp_path, {'scene': 'tiny'}, bundled_scene('tiny'))
    with pytest.raises(LibraryError, match="for scene 'tiny', not 'reduced_1ms'"):
        check_library_scene(tmp_path, {'scene': 'tiny'}, bundled_scene('reduced_1ms'))


ROOT = Path(__file__).resolve().parents[3]


def test_one_marker_is_inconclusive_with_the_markers_it_needs(tmp_path: Path) -> None:
    """The field twin's marker 3 alone through the shipped library: no effect is named (it
    used to print 'cohesion p = 1.000' without a word); the verdict says why and what it needs.
    All 15 markers of the same pass still name the effect."""
    import json

    from dempath_diagnose.cli import diagnose_main

    rows = (ROOT / 'bags' / 'field_twin_reduced_1ms.truth.csv').read_text().splitlines()
    one = tmp_path / 'one.csv'
    one.write_text('\n'.join([rows[0], *(r for r in rows[1:] if r.split(',')[1] == '3')]))
    verdicts = {}
    for name, measured in (('one', one), ('all', ROOT / 'bags' /
                                          'field_twin_reduced_1ms.truth.csv')):
        code = diagnose_main(['--measured', str(measured), '--scene', 'reduced_1ms',
                              '--library', str(SHIPPED), '--origin', '0.05,0,0.45', '--out',
                              str(tmp_path / name)])
        assert code == 0
        verdicts[name] = json.loads((tmp_path / name / 'diagnosis.json').read_text())
    assert verdicts['all']['verdict'] == 'effect_missing'
    assert verdicts['one']['verdict'] == 'inconclusive'
    assert verdicts['one']['notes'][0].startswith(
        'thin measurement: 1 marker (1 on the tool axis, 0 beside it); naming an effect needs '
        'at least 3 markers')


@pytest.mark.parametrize(('extra', 'needle'), [
    (['--effect', 'nonsense'], '--effect nonsense: not a candidate'),
    (['--diagnosis', 'missing/diagnosis.json'], 'not a readable diagnosis.json'),
])
def test_recalibrate_option_errors_come_before_any_work(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str],
        needle: str) -> None:
    """A bad --effect or --diagnosis: one error line and no output folder (the diagnosis used
    to be computed and written first)."""
    from dempath_diagnose.recalibrate_cli import recalibrate_main

    out = tmp_path / 'recal'
    code = recalibrate_main(['--measured', str(ROOT / 'bags' / 'field_twin_reduced_1ms.truth.csv'),
                             '--scene', 'reduced_1ms', '--library', str(SHIPPED), '--origin',
                             '0.05,0,0.45', '--out', str(out), *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and needle in err[0], err
    assert not out.exists()


def test_marker_file_shifted_by_minus_five_seconds_is_one_line(tmp_path: Path) -> None:
    """Marker times starting at -5 s: one MeasurementError (an IndexError traceback before)."""
    from dempath_diagnose.decision.measure import load_tracks

    rows = (ROOT / 'bags' / 'field_twin_reduced_1ms.truth.csv').read_text().splitlines()
    shifted = tmp_path / 'shifted.csv'
    shifted.write_text('\n'.join([rows[0], *(
        ','.join([f'{float(r.split(",")[0]) - 5.0:.4f}', *r.split(',')[1:]]) for r in rows[1:])]))
    with pytest.raises(MeasurementError, match=r't runs from -5.000 to -4.\d+ s'):
        load_tracks(shifted)
