"""Benchmark: ``dempath demo`` as ``make demo`` runs it, timed per stage.

Runs the demo in a child process (``.venv/bin/dempath demo``, arguments passed through, output
shown as it comes) and reads the ``timing.json`` it writes. The last line is one JSON object:

- ``wall_s``: wall time of the whole command, process start-up and imports included [s];
- ``stages``: seconds per named stage (calibration, graph, ...);
- ``traj_rms_mm``: RMS distance of the reconstructed 3D markers from the recording's true ones
  (the rendered recording's truth file) [mm];
- ``verdict`` of the diagnosis and ``recalibration``: the fitted effect and strength with its
  uncertainty, d^2 before and after beside the floor ``k``, the fraction of the error above the
  floor removed (null for stages that did not run); ``mean_nrmse_pct``: the recording's mean
  nRMSE against the model before and after, per tool speed (timing.json);
- ``exit_code``, ``load_average`` (1 min, at the end) and ``cpus`` of the machine.

``DEMPATH_SCREENSHOTS=1`` also opens the report in headless Chromium, checks that every figure
is decoded and shown, and keeps the whole page as docs/demo_report.png.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def _json(path: Path) -> dict[str, Any] | None:
    return json.loads(path.read_text()) if path.is_file() else None


def model_figures(out: Path) -> dict[str, Any]:
    """The diagnosis' verdict and the recalibration's figures from the demo's outputs."""
    diag = _json(out / 'diagnosis' / 'diagnosis.json')
    recal = _json(out / 'recalibration' / 'recalibration.json')
    figures: dict[str, Any] = {'verdict': diag['verdict'] if diag else None,
                               'recalibration': None}
    if recal:
        s = recal['strength']
        figures['recalibration'] = {
            'effect': recal['effect'], 'parameter': recal['parameter'],
            'changed': recal['changed'], 'value': s['value'], 'uncertainty': s['uncertainty'],
            'd2_before': round(recal['error_before'], 2),
            'd2_after': round(recal['error_after'], 2), 'floor_k': recal['floor']['k'],
            'error_reduction': recal['error_reduction'], 'simulations': recal['simulations'],
            'stopped_on': recal.get('stopped_on'),
            'd2_floor_band': ([round(b[k], 2) for k in ('low', 'high')]
                              if (b := (recal.get('floor_bands') or [None])[-1]) else None)}
        paper = recal.get('paper') or {}
        for key in ('headline', 'headline_held_out'):
            entry = paper.get(key) or {}
            figures[key] = {k: {'value_mm': round(e['value_mm'], 2), 'place': e['place'],
                                'floor_mm': [round(e['floor_mm'][b], 2) for b in ('low', 'high')]}
                            for k, e in entry.items()
                            if isinstance(e, dict) and e.get('value_mm') is not None}
            if entry.get('markers'):
                figures[key]['markers'] = entry['markers']
    return figures


def screenshot_report(page: Path, path: Path) -> list[str]:
    """Save Chromium's screenshot of the whole report; the figures it did not show."""
    from selenium.webdriver.common.by import By

    from dempath.browser import headless_chromium

    browser = headless_chromium(1280, 2400)
    try:
        browser.get(page.as_uri())
        missing = [str(img.get_attribute('src')) for img in
                   browser.find_elements(By.TAG_NAME, 'img') if not browser.execute_script(
                       'return arguments[0].complete && arguments[0].naturalWidth;', img)]
        height = browser.execute_script('return document.documentElement.scrollHeight;')
        browser.set_window_size(1280, min(int(height) + 40, 12000))
        browser.save_screenshot(str(path))
    finally:
        browser.quit()
    return missing


def main(argv: list[str]) -> int:
    """Run the demo once and print the JSON line."""
    out = ROOT / 'out' / 'bench_demo'
    dempath = ROOT / '.venv' / 'bin' / 'dempath'
    cmd = [str(dempath), 'demo', '--data', str(ROOT / 'bags'), '--out', str(out), *argv]
    t0 = time.monotonic()
    code = subprocess.call(cmd, cwd=ROOT)
    wall = time.monotonic() - t0
    timing_path = out / 'timing.json'
    timing = json.loads(timing_path.read_text()) if timing_path.is_file() else {}
    figures = {'wall_s': round(wall, 1), 'stages': timing.get('stages', {}),
               'traj_rms_mm': timing.get('traj_rms_mm'),
               'mean_nrmse_pct': timing.get('mean_nrmse_pct'), **model_figures(out),
               'exit_code': code,
               'load_average': round(os.getloadavg()[0], 2), 'cpus': os.cpu_count()}
    page = out / 'report' / 'index.html'
    if os.environ.get('DEMPATH_SCREENSHOTS') == '1' and page.is_file():
        figures['report_figures_not_shown'] = screenshot_report(
            page, ROOT / 'docs' / 'demo_report.png')
    print(json.dumps(figures))
    return code


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
