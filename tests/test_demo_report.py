"""The whole demo on the tiny scene, diagnosis and recalibration included, and its HTML report
checked in a real browser.

The test builds a small signature library for the tiny scene first (two packing seeds, one
candidate effect, one strength: ``dempath diagnose`` builds it), packs it into one file as the
demo's shipped ``reduced_1ms`` library is, and runs ``dempath demo --clicked --library FILE`` on
the tiny field twin with it: calibration,
graph, comparison, diagnosis, recalibration (two simulations: one evaluation over both seeds),
the recalibrated model, report.
A second run without any library must say that the library is missing and still write the
report. The report is opened in headless Chromium (installed through apt when missing and
allowed, else the browser test skips with the reason). docs/demo_report.png is the real demo's
report (``DEMPATH_SCREENSHOTS=1 python bench/demo.py``), not this tiny one.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from dempath.browser import BrowserNotFoundError, headless_chromium
from dempath.nodes.pytest_plugin import require_component
from dempath_bringup.demo import demo_main
from dempath_diagnose.cli import diagnose_main

# builds a small library, then runs the demo twice: long on a loaded machine
pytestmark = pytest.mark.timeout(2400)
ROOT = Path(__file__).resolve().parents[1]
BAGS = ROOT / 'bags'
FIELD = BAGS / 'field_twin_tiny'
LIBRARY = ['--seeds', '1001,1002', '--candidates', 'tool_speed', '--strengths', '1']
FIGURES = ('calibration.png', 'trajectories.png', 'error_map.png', 'error_vs_iteration.png',
           'recalibration_trajectories.png', 'coverage.png')


@pytest.fixture(scope='module')
def demo_out(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, int, str]]:
    """(output folder, exit code, stdout) of the tiny demo with a freshly built library."""
    tmp = tmp_path_factory.mktemp('demo')
    truth = json.loads((BAGS / 'field_twin_tiny.truth.json').read_text())
    origin = ','.join(str(v) for v in truth['field_origin_in_scene_m'])
    common = ['--library-root', str(tmp / 'library'), '--packing-cache', str(tmp / 'packings'),
              *LIBRARY]
    packed = tmp / 'tiny_library.npz'  # packed, as the demo's shipped library is
    code = diagnose_main(['--measured', str(BAGS / 'field_twin_tiny.truth.csv'), '--scene',
                          'builtin:tiny', '--origin', origin, '--out', str(tmp / 'build'),
                          '--serial', '--export-library', str(packed), *common])
    assert code == 0, 'building the small tiny library failed'
    out = tmp / 'out'
    capture = tmp / 'stdout.txt'
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = demo_main(['--clicked', '--field-bag', str(FIELD), '--calib-bag',
                          str(BAGS / 'calib_twin_small'), '--scene', 'builtin:tiny', '--out',
                          str(out), '--budget', '2', '--effect', 'tool_speed', '--library',
                          str(packed), '--packing-cache', str(tmp / 'packings')])
    capture.write_text(buf.getvalue())
    yield out, code, buf.getvalue()


def test_demo_diagnoses_recalibrates_and_reports(demo_out: tuple[Path, int, str]) -> None:
    """Every stage ran; the report holds each section and every figure beside it."""
    out, code, stdout = demo_out
    assert code == 0, stdout[-3000:]
    timing = json.loads((out / 'timing.json').read_text())
    assert list(timing['stages']) == ['calibration', 'graph', 'comparison outputs', 'diagnosis',
                                      'recalibration', 'model after', 'report']
    diagnosis = json.loads((out / 'diagnosis' / 'diagnosis.json').read_text())
    assert {r['effect'] for r in diagnosis['ranking']} >= {'tool_speed'}
    total = sum(r['probability'] for r in diagnosis['ranking'])
    assert abs(total + diagnosis['baseline']['probability'] - 1.0) < 1e-3
    recal = json.loads((out / 'recalibration' / 'recalibration.json').read_text())
    assert recal['simulations'] >= 1 or not recal['changed']
    page = (out / 'report' / 'index.html').read_text()
    for section in ('1. Calibration', '2. Detection', '3. Measured against the model',
                    '4. Diagnosis', '5. Recalibration', 'Table 7, before'):
        assert section in page, section
    assert 'tool_speed' in page
    # each error before and after beside its own like-for-like floor, or beside none: with
    # two library seeds no like-for-like d^2 band can be computed (it needs three), so the
    # loop's stop is named as the nominal chi^2 mean, not printed as a floor
    assert 'floor before' in page and 'floor after' in page
    assert recal['stopped_on'] == 'the nominal chi^2 mean k'
    assert f"nominal chi<sup>2</sup> mean k = {recal['floor']['k']:g}" in page
    # the grid's middle column is held out of the diagnosis and the fit, scored apart
    assert diagnosis['held_out'] == [3, 8, 13] and '8' not in diagnosis['markers_in_windows']
    paper = recal.get('paper')
    if paper:
        held = paper['headline_held_out']
        assert held['markers'] == [3, 8, 13] and 'value_mm' in held['before']
        assert 'held-out markers 3, 8, 13 (not fitted)' in page
        assert f"{paper['floor']['mean_nrmse_pct']:.2f} +- " in page
        if paper.get('floor_after'):
            assert f"{paper['floor_after']['mean_nrmse_pct']:.2f} +- " in page
        iterations = paper['headline_iterations']
        assert iterations[0]['label'] == 'before'
        assert all('value_mm' in it or 'error' in it for it in iterations)
        if recal['simulations'] > 0:  # each evaluated iteration has its headline
            assert len(iterations) >= 2 and iterations[1]['label'].startswith('iteration 1')
        assert 'src="headline_iterations.png"' in page
    for name in FIGURES:
        assert (out / 'report' / name).is_file(), name
        assert f'src="{name}"' in page, name


def test_demo_without_library_says_so_and_goes_on(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """No signature library: one MISSING line, diagnosis and recalibration skipped, report made."""
    out = tmp_path / 'out'
    code = demo_main(['--clicked', '--field-bag', str(FIELD), '--calib-bag',
                      str(BAGS / 'calib_twin_small'), '--scene', 'builtin:tiny', '--out', str(out),
                      '--library-root', str(tmp_path / 'empty'), *LIBRARY])
    stdout = capsys.readouterr().out
    assert code == 0, stdout[-3000:]
    missing = [ln for ln in stdout.splitlines() if 'MISSING' in ln]
    assert len(missing) == 1 and 'signature library' in missing[0], stdout[-3000:]
    page = (out / 'report' / 'index.html').read_text()
    assert 'Not run' in page and 'signature library' in page
    assert not (out / 'recalibration').exists()


@pytest.fixture
def browser() -> Iterator[Any]:
    """A headless Chromium (apt-installed when missing and allowed, else the test fails)."""
    try:
        driver = headless_chromium(1280, 2400)
    except BrowserNotFoundError as err:
        require_component('chromium', err)
    yield driver
    driver.quit()


def test_report_in_a_real_browser(demo_out: tuple[Path, int, str], browser: Any,
                                  tmp_path: Path) -> None:
    """Chromium shows every figure (decoded, non-zero size) and both Table 7s."""
    from selenium.webdriver.common.by import By

    out, code, _ = demo_out
    assert code == 0
    browser.get((out / 'report' / 'index.html').as_uri())
    images = browser.find_elements(By.TAG_NAME, 'img')
    shown = {Path(img.get_attribute('src')).name: browser.execute_script(
        'return arguments[0].complete && arguments[0].naturalWidth;', img) for img in images}
    for name in FIGURES:
        assert shown.get(name), f'{name} not shown: {shown}'
    tables = browser.find_elements(By.TAG_NAME, 'table')
    assert len(tables) >= 4  # calibration, Table 7 before and after, ranking
    height = browser.execute_script('return document.documentElement.scrollHeight;')
    browser.set_window_size(1280, min(int(height) + 40, 9000))  # the whole page in one image
    browser.save_screenshot(str(tmp_path / 'report.png'))
    assert (tmp_path / 'report.png').stat().st_size > 0
