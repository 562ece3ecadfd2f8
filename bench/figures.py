"""Regenerate every figure the docs show, from the current code, with one command.

Each doc figure has the command that makes it; this runs them in order (each bench caches what
it can, so a second run redoes only what changed) and copies the results into docs/:

- ``marker_coverage``: bench/marker_coverage.py --detected on the bundled rendered recording
  (JSON only; the error fall's ``markers_reconstructed``, through the demo's detection and
  reconstruction);
- ``error_fall``: bench/error_fall.py -> docs/error_fall.png and the per-case table
  (out/figures/error_fall.md, the table in docs/figures.md);
- ``demo_report``: bench/demo.py with ``DEMPATH_SCREENSHOTS=1`` (a fresh ``dempath demo`` run)
  -> docs/demo_report.png, and its JSON line (the demo rows of docs/figures.md);
- ``clicker``: the clicker's browser test with ``DEMPATH_SCREENSHOTS=1`` -> docs/clicker.png;
- ``repose`` (slow, only with ``--slow``: three DEM piles): ``dempath validate --cases repose``
  -> docs/validation_repose_profile.png.

Usage: ``nice -n 10 .venv/bin/python bench/figures.py [--only NAME ...] [--slow]`` (also
``make figures``). Prints a line per figure and one JSON line last: per figure its exit code,
wall time [s] and the files written.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PY = str(ROOT / '.venv' / 'bin' / 'python')
OUT = ROOT / 'out' / 'figures'


def steps() -> dict[str, tuple[list[str], dict[str, str], list[tuple[Path, Path]]]]:
    """name -> (command, extra environment, (made, copied to) pairs)."""
    shots = {'DEMPATH_SCREENSHOTS': '1'}
    repose = OUT / 'repose'
    return {
        'marker_coverage': ([PY, 'bench/marker_coverage.py', '--detected', '--out',
                             str(OUT / 'marker_coverage.json')], {}, []),
        'error_fall': ([PY, 'bench/error_fall.py', '--cache', 'out/bench_error_fall',
                        '--figure', 'docs/error_fall.png', '--markdown',
                        str(OUT / 'error_fall.md'), '--reconstructed',
                        str(OUT / 'marker_coverage.json')], {}, []),
        'demo_report': ([PY, 'bench/demo.py'], shots, []),
        'clicker': ([PY, '-m', 'pytest', 'tests/test_clicker_browser.py', '-q', '-n', '0'],
                    shots, []),
        'repose': ([str(ROOT / '.venv' / 'bin' / 'dempath'), 'validate', '--cases', 'repose',
                    '--repose-seeds', '3', '--np', '1', '--out', str(repose)], {},
                   [(repose / 'repose.png', ROOT / 'docs' / 'validation_repose_profile.png')]),
    }


SLOW = ('repose',)


def main(argv: list[str]) -> int:
    """Run the chosen figure commands; one JSON line last."""
    p = argparse.ArgumentParser()
    p.add_argument('--only', nargs='*', help='figures to make (default: all but the slow)')
    p.add_argument('--slow', action='store_true', help='also the slow ones (the repose piles)')
    args = p.parse_args(argv)
    table = steps()
    chosen = args.only or [n for n in table if args.slow or n not in SLOW]
    unknown = sorted(set(chosen) - set(table))
    if unknown:
        print(f'error: --only: unknown figure(s) {unknown}; known: {sorted(table)}',
              file=sys.stderr)
        return 1
    OUT.mkdir(parents=True, exist_ok=True)
    done: dict[str, dict[str, object]] = {}
    for name in chosen:
        cmd, env, copies = table[name]
        t0 = time.monotonic()
        with (OUT / f'{name}.log').open('w') as log:
            code = subprocess.call(cmd, cwd=ROOT, env={**os.environ, **env}, stdout=log,
                                   stderr=subprocess.STDOUT)
        written = []
        for made, to in copies:
            if code == 0 and made.is_file():
                shutil.copyfile(made, to)
                written.append(str(to.relative_to(ROOT)))
        last = (OUT / f'{name}.log').read_text().strip().splitlines()
        done[name] = {'exit_code': code, 'wall_s': round(time.monotonic() - t0, 1),
                      'written': written, 'last_line': last[-1][:2000] if last else ''}
        print(f'{name}: exit {code}, {done[name]["wall_s"]} s (log: {OUT / name}.log)',
              flush=True)
    print(json.dumps({'figures': done, 'failed': [n for n, d in done.items()
                                                   if d['exit_code']]}))
    return 1 if any(d['exit_code'] for d in done.values()) else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
