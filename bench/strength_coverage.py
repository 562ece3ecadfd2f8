"""Coverage of the fitted strengths' uncertainties on a signature library (no simulation).

Leave-one-seed-out on the library's own runs, each turned into a camera-like measurement (one
particle per marker, 1.5 mm noise, the run's force), diagnosed for its own candidate; see
:mod:`dempath_diagnose.decision.coverage`. Prints a line per candidate and one JSON object last:
``checks`` (n), ``mean_z``, ``rms_z`` and ``beyond_2sd`` overall and per candidate.

Usage: ``.venv/bin/python bench/strength_coverage.py [--scene reduced_1ms] [--library FILE_OR_DIR]
[--measured CSV]`` (default: the shipped library of the scene, the scene's marker grid; with
``--measured`` the layout of that measurement's markers).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from dempath_diagnose.decision.coverage import strength_checks, summary
from dempath_diagnose.decision.measure import load_tracks
from dempath_diagnose.library.simulator import load_scene, tool_geometry
from dempath_diagnose.library.store import Library

SHIPPED = Path(__file__).resolve().parents[1] / (
    'src/dempath_diagnose/dempath_diagnose/data/libraries')


def grid_starts(scene: object, library: Library) -> tuple[np.ndarray, np.ndarray]:
    """The scene's marker grid: at each grid point the highest baseline particle within 10 mm."""
    from dempath_sim.runs.markers import grid_xz

    numbers, xz = grid_xz(scene.markers)  # type: ignore[attr-defined]
    base = next(library.records[r.filename] for r in library.runs if r.candidate == '')
    starts = []
    for x, z in xz:
        near = np.flatnonzero(np.hypot(base.start[:, 0] - x, base.start[:, 2] - z) < 0.01)
        starts.append(base.start[near[np.argmax(base.start[near, 1])]])
    return np.asarray(numbers, np.float64), np.array(starts)


def main() -> None:
    """Run the check and print one JSON line last."""
    p = argparse.ArgumentParser()
    p.add_argument('--scene', default='reduced_1ms')
    p.add_argument('--library', type=Path)
    p.add_argument('--measured', type=Path, help='take the marker layout from this measurement')
    args = p.parse_args()
    scene = load_scene(args.scene)
    library = Library.load(args.library or SHIPPED / f'{scene.name}_library.npz')
    if args.measured is not None:
        meas = load_tracks(args.measured)
        markers, starts = meas.markers.astype(np.float64), meas.start
    else:
        markers, starts = grid_starts(scene, library)
    tool_x, half_width, cube = tool_geometry(scene)
    checks = strength_checks(library, markers, starts, tool_x, half_width, cube)
    figures = summary(checks)
    for name, row in sorted(figures.items()):
        print(f'{name:20s} n {row["n"]:3d}  mean z {row["mean_z"]:+.2f}  rms z {row["rms_z"]:.2f}'
              f'  |z| > 2: {row["beyond_2sd"]:.0%}')
    print(json.dumps({'scene': scene.name, 'library': str(library.folder),
                      'checks': len(checks), **figures['all'], 'per_candidate': figures}))


if __name__ == '__main__':
    main()
