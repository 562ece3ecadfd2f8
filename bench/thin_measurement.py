"""Is the thin-measurement rule calibrated? Hidden-effect cases diagnosed on marker subsets.

The diagnosis makes its verdict ``inconclusive`` when a measurement has fewer than
``MIN_MARKERS`` markers, or none on the tool axis, or none beside the tool
(:func:`dempath_diagnose.decision.thin.thin_measurement`). This bench checks that rule against what
the method does without it: every hidden-effect case of ``bench/diagnose.py`` (their cached
library and case passes under ``--root``) is diagnosed again on random subsets of its markers
(sizes 1, 2, 3, 4, 6 and all; ``--draws`` subsets per size, with the force and without) and each
answer is scored twice:

- ``raw``: the verdict the method gives without the rule (recomputed from the diagnosis'
  emulator, statistics and covariance);
- ``printed``: the verdict the product prints (the rule applied).

The rule is right when raw confident answers (a named effect, p >= 0.8) on thin subsets are
wrong more often than their probability allows, and the printed answers are never confidently
wrong. The figures per subset size: answers, raw confident answers, their hit rate and mean
probability, printed confident answers and their hit rate, the Brier score of the top
probability. Everything costly (library, cases) is cached by ``bench/diagnose.py``; this bench
only diagnoses. The last line is one JSON object.

Usage: ``.venv/bin/python bench/diagnose.py --scene tiny --serial --library-only --root DIR``
once, then ``.venv/bin/python bench/thin_measurement.py --scene tiny --root DIR``.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from dempath_diagnose.decision.diagnosis import CaseGeometry, diagnose
from dempath_diagnose.decision.measure import load_force, load_tracks
from dempath_diagnose.decision.thin import MIN_MARKERS
from dempath_diagnose.decision.verdict import CONFIDENT, decide
from dempath_diagnose.library.cases import HiddenCase, make_case
from dempath_diagnose.library.simulator import load_scene, pass_travel_s, tool_geometry
from dempath_diagnose.library.store import (
    Library,
    LibrarySpec,
    build_library,
    covering_duration,
    serial_executor,
)

sys.path.insert(0, str(Path(__file__).parent))
from diagnose import NAMED, cases_for

SIZES = (1, 2, 3, 4, 6, 0)  # 0: every marker


def marker_rows(path: Path) -> tuple[list[str], list[list[str]]]:
    """The header and rows of a measured CSV ``t,marker,x,y,z``."""
    with path.open(newline='', encoding='utf-8') as f:
        reader = csv.reader(f)
        header = next(reader)
        return header, list(reader)


def write_subset(header: list[str], rows: list[list[str]], keep: set[int], path: Path) -> Path:
    """The measured CSV with the markers in ``keep`` only."""
    col = header.index('marker')
    with path.open('w', newline='', encoding='utf-8') as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows(r for r in rows if int(float(r[col])) in keep)
    return path


def right(case: HiddenCase, verdict: str, top: str) -> bool:
    """A named verdict is right when it names the truth; an open one when there is none."""
    if verdict in NAMED:
        return top == case.truth
    return not case.truth


def answer(case: HiddenCase, markers: Path, force: Path | None, library: Library,
           geometry: CaseGeometry) -> dict[str, Any]:
    """One diagnosis of a subset: the raw and the printed verdict and the top probability."""
    meas = load_tracks(markers)
    if force is not None:
        t, f = load_force(force)
        meas = replace(meas, force_times=t, force=f)
    result = diagnose(meas, library, geometry, force_source=force or 'force')
    raw = decide(result.emulator, result.measured, result.observed, result.cov)
    top = raw.ranking[0]
    printed = result.decision.verdict
    return {'case': case.name, 'truth': case.truth, 'markers': len(result.layout.markers),
            'top': top.name, 'p': float(top.probability), 'raw': raw.verdict,
            'printed': printed, 'thin': printed != raw.verdict or any(
                'thin measurement' in n for n in result.decision.notes),
            'raw_right': right(case, raw.verdict, top.name),
            'printed_right': right(case, printed, top.name),
            'p_truth': float(next((r.probability for r in raw.ranking if r.name == case.truth),
                                  0.0)) if case.truth else float('nan')}


def size_figures(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per subset size: answers, raw and printed confident answers and their hit rates."""
    raw_conf = [r for r in rows if r['raw'] in NAMED and r['p'] >= CONFIDENT]
    printed_conf = [r for r in rows if r['printed'] in NAMED]
    return {
        'answers': len(rows),
        'raw_confident': len(raw_conf),
        'raw_confident_hit_rate': round(float(np.mean([r['raw_right'] for r in raw_conf])), 3)
        if raw_conf else None,
        'raw_confident_mean_p': round(float(np.mean([r['p'] for r in raw_conf])), 3)
        if raw_conf else None,
        'raw_confident_wrong': sum(not r['raw_right'] for r in raw_conf),
        'printed_confident': len(printed_conf),
        'printed_confident_wrong': sum(not r['printed_right'] for r in printed_conf),
        'printed_thin': sum(r['thin'] for r in rows),
    }


def main() -> None:
    """Diagnose every case on marker subsets and print the figures, one JSON line last."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument('--scene', default='tiny')
    p.add_argument('--root', type=Path, default=Path.home() / '.cache/dempath/bench-diagnose')
    p.add_argument('--seeds', default='1001,1002,1003')
    p.add_argument('--strengths', type=int, default=2)
    p.add_argument('--draws', type=int, default=4, help='random subsets per size and case')
    args = p.parse_args()
    scene = load_scene(args.scene)
    duration = covering_duration(pass_travel_s(scene, {}), 0.0)
    from dempath_diagnose.library.simulator import LIBRARY_CANDIDATES

    spec = LibrarySpec(seeds=tuple(int(s) for s in args.seeds.split(',')), duration_s=duration,
                       n_strengths=args.strengths, candidates=tuple(LIBRARY_CANDIDATES))
    packings = args.root / 'packings'
    library = Library.load(build_library(scene, spec, args.root / 'library', serial_executor,
                                         packings))
    x, half, cube = tool_geometry(scene)
    geometry = CaseGeometry(x, half, cube)
    rng = np.random.default_rng(20261128)
    rows: list[dict[str, Any]] = []
    for case in cases_for(scene.name):
        folder = args.root / 'cases' / case.name
        markers, force = make_case(scene, case, folder, until_s=duration, cache_dir=packings)
        header, data = marker_rows(markers)
        ids = sorted({int(float(r[header.index('marker')])) for r in data})
        subsets = folder / 'subsets'
        subsets.mkdir(exist_ok=True)
        for size in SIZES:
            k = len(ids) if size == 0 else size
            if k > len(ids):
                continue
            draws = 1 if k == len(ids) else args.draws
            for d in range(draws):
                keep = {int(i) for i in rng.choice(ids, size=k, replace=False)}
                path = write_subset(header, data, keep, subsets / f'k{k}_d{d}.csv')
                for with_force in (True, False):
                    try:
                        row = answer(case, path, force if with_force else None, library,
                                     geometry)
                    except Exception as err:  # a subset the diagnosis refuses: say which
                        row = {'case': case.name, 'size': k, 'error': str(err).splitlines()[0]}
                        print(json.dumps(row), flush=True)
                        continue
                    row.update(size=k, force=with_force, all_markers=k == len(ids))
                    rows.append(row)
                    print(json.dumps(row), flush=True)
    by_size: dict[str, Any] = {}
    for k in sorted({r['size'] for r in rows}):
        by_size[str(k)] = size_figures([r for r in rows if r['size'] == k])
    thin = [r for r in rows if r['markers'] < MIN_MARKERS]
    full = [r for r in rows if r['markers'] >= MIN_MARKERS]
    figures = {
        'scene': scene.name, 'min_markers': MIN_MARKERS, 'answers': len(rows),
        'by_size': by_size,
        'below_min': size_figures(thin), 'at_or_above_min': size_figures(full),
        'printed_confident_wrong': sum(r['printed'] in NAMED and not r['printed_right']
                                       for r in rows),
    }
    print(json.dumps(figures))


if __name__ == '__main__':
    main()
