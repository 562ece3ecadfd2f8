"""Watch the error fall, honestly: hidden-effect cases on the shipped reduced_1ms library.

Each case is a library run on one packing seed playing the measurement (every marker, every
sample of the 0.82 s pass, 1.5 mm noise), diagnosed and fitted with the other seeds only; the
headline error (energy score against the model's cube candidates over seeds) before, after the
true candidate's fit and after the best wrong candidate's fit, each beside its like-for-like
floor band; the held-out markers (3, 8, 13: the middle column of the grid, left out of the fit)
before and after; the paper's Table 7 like for like (same markers, samples, pools, N = 10)
before, after and its floor. See :mod:`dempath_diagnose.headline.fall`. No simulation runs.

Cases: cohesion 1e5 (strong) and 2e4 (moderate) J/m^3, tool speed x1.5 and x0.6, tool friction
0.6 and 0.24, and the control (the baseline), each on seeds 1001-1003: the cases the floor band
and the rival test were chosen on. Held out from that choice (run after it was fixed; summary
figures apart under ``held_out``): cohesion 5e4, tool speed x1.2, rolling resistance 0.39,
Young's modulus x3. Held out from session 13's change (``held_out_2``, chosen before any was
run): particle friction 1.065, restitution 0.18, rolling resistance 0.156, cohesion 7e4
(strengths between or at the library's runs: emulated, ``headline/ensemble``). A fit is *in its
floor* when its headline lies at or below its floor band, it scores significantly lower than the
model before the fit and the other fit does not score significantly lower, marker by marker
(``headline/compare.py``); both fits in their floors: *cannot separate* (counted apart). The
wrong fit is the best wrong candidate whose model can be scored (any skipped is listed). Every
finished case is stored in ``--cache`` at once (resumable). Prints a line per case and one JSON
line last.

Usage: ``nice -n 10 .venv/bin/python bench/error_fall.py [--cache DIR] [--seeds 1001,...]
[--no-table7] [--no-held-out-cases] [--markdown T] [--figure PNG] [--reconstructed JSON]``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from dempath_diagnose.headline.fall import (
    D2_VERSION,
    FallCase,
    FallSetup,
    redo_d2,
    run_case,
    separation,
    state,
    summary,
    with_falls,
)
from dempath_diagnose.library.simulator import load_scene, tool_geometry
from dempath_diagnose.library.store import Library

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / 'src/dempath_diagnose/dempath_diagnose/data/libraries/reduced_1ms_library.npz'
CASES = (('cohesion_strong', 'cohesion', 1e5), ('cohesion_moderate', 'cohesion', 2e4),
         ('tool_speed_x1.5', 'tool_speed', 1.5), ('tool_speed_x0.6', 'tool_speed', 0.6),
         ('tool_friction_0.6', 'tool_friction', 0.6),
         ('tool_friction_0.24', 'tool_friction', 0.24), ('control', '', 0.0))
# Cases kept out of the choice of the method (issue 26's session 12: the floor's seed-aware
# bound was chosen on the seven cases above only; these were run after it was fixed).
HELD_OUT_CASES = (('cohesion_5e4', 'cohesion', 5e4), ('tool_speed_x1.2', 'tool_speed', 1.2),
                  ('rolling_resistance_0.39', 'rolling_resistance', 0.39),
                  ('youngs_modulus_x3', 'youngs_modulus', 5.1e6))
# Chosen after the session-13 change of the method (a fit is at its floor only when it also
# lowered the error; 'cannot separate'), before any of them was run or looked at.
HELD_OUT_CASES_2 = (('particle_friction_1.065', 'particle_friction', 1.065),
                    ('restitution_0.18', 'restitution', 0.18),
                    ('rolling_resistance_0.156', 'rolling_resistance', 0.156),
                    ('cohesion_7e4', 'cohesion', 7e4))
HELD_OUT = (3, 8, 13)
CASE_SETS = {'tuned': CASES, 'held_out': HELD_OUT_CASES, 'held_out_2': HELD_OUT_CASES_2}


def main() -> None:
    """Run (or resume) every case and print the summary as one JSON line last."""
    p = argparse.ArgumentParser()
    p.add_argument('--cache', type=Path, default=Path('out/bench_error_fall'))
    p.add_argument('--seeds', default='1001,1002,1003')
    p.add_argument('--no-table7', action='store_true')
    p.add_argument('--no-held-out-cases', action='store_true',
                   help='only the cases the method was chosen on')
    p.add_argument('--markdown', type=Path, help='write the per-case table (Markdown) here')
    p.add_argument('--figure', type=Path, help='write the picture of every case (PNG) here')
    p.add_argument('--reconstructed', type=Path,
                   help='JSON of bench/marker_coverage.py (markers reconstructed on the twin)')
    args = p.parse_args()
    scene = load_scene('reduced_1ms')
    library = Library.load(SHIPPED)
    tool_x, half, cube = tool_geometry(scene)
    starts = np.array(library.region['starts'])
    setup = FallSetup(np.arange(1, len(starts) + 1, dtype=np.float64), starts, HELD_OUT,
                      tool_x, half, cube)
    args.cache.mkdir(parents=True, exist_ok=True)
    results, floors = [], {}
    seeds = [int(s) for s in args.seeds.split(',')]
    order = [(seed, c) for seed in seeds for c in CASES]
    if not args.no_held_out_cases:
        order += [(seed, c) for seed in seeds for c in HELD_OUT_CASES]
        order += [(seed, c) for seed in seeds for c in HELD_OUT_CASES_2]
    for seed, (name, cand, strength) in order:
        path = args.cache / f'{name}-s{seed}.json'
        if path.is_file():
            res = json.loads(path.read_text())
            if res.get('d2', {}).get('version') != D2_VERSION:  # stored before d^2's floor
                res['d2'] = redo_d2(library, FallCase(name, cand, strength, seed), setup,
                                    floors)
                path.write_text(json.dumps(res))
        else:
            res = run_case(library, FallCase(name, cand, strength, seed), setup,
                           not args.no_table7, floors)
            tmp = path.with_suffix('.tmp')
            tmp.write_text(json.dumps(res))
            tmp.replace(path)
        for part in ('all', 'held_out'):  # stored before the fall test: add it
            with_falls(res[part])
        res['case_set'] = next(k for k, v in CASE_SETS.items() if name in {c[0] for c in v})
        results.append(res)
        print(line(res), flush=True)
    if args.markdown:
        args.markdown.write_text(markdown(results))
    if args.figure:
        from dempath_diagnose.headline.plots import plot_error_fall

        plot_error_fall(results, args.figure)
    out = summary(results, table7_like_for_like=not args.no_table7)
    for part in CASE_SETS:
        some = [r for r in results if r['case_set'] == part]
        if some:
            sub = summary(some, table7_like_for_like=not args.no_table7)
            out[part] = {k: sub[k] for k in ('cases', 'effect_seen', 'true_fit_in_floor',
                                             'wrong_fit_in_floor', 'cannot_separate',
                                             'control_moved')}
    out['markers_reconstructed'] = None
    if args.reconstructed and args.reconstructed.is_file():
        out['markers_reconstructed'] = json.loads(args.reconstructed.read_text()).get(
            'markers_reconstructed')
    print(json.dumps(out))


def markdown(results: list[dict]) -> str:
    """The per-case table: headline [mm] and Table 7 [%], each 'value (floor band) place'."""
    def cell(f: dict | None, unit: str = '') -> str:
        if not f:
            return '-'
        fl = f['floor']
        mark = {'above': '**above**', 'in': 'in', 'below': 'below'}[f['place']]
        if f.get('rival', {}).get('lower'):
            mark += f", **rival lower** (p {f['rival']['p']:.3f})"
        elif 'fall' in f and f['place'] != 'above' and not f['fall']['lower']:
            mark += ', **no fall**'
        return f"{f['value']:.1f} ({max(fl['low'], 0.0):.1f}-{fl['high']:.1f}) {mark}"

    rows = ['| case | seed | verdict | headline before | true fit (strength) | after true '
            '| best wrong fit | after wrong | fits | held-out before -> after | d^2 before '
            '| d^2 after true | Table 7 before | Table 7 after |', '|' + ' --- |' * 14]
    for r in results:
        a, h, t7, d2 = r['all'], r['held_out'], r.get('table7', {}), r.get('d2', {})
        fit = (f"{r['true_fit']['strength']:.3g}" if 'true_fit' in r else '-')
        held = (f"{h['before']['value']:.1f} -> {h['after_true']['value']:.1f}"
                if 'after_true' in h else f"{h['before']['value']:.1f}")
        rows.append(f"| {r['case']} | {r['seed']} | {r['verdict']} | {cell(a['before'])} | "
                    f"{fit} | {cell(a.get('after_true'))} | {r['wrong_fit']['candidate']} | "
                    f"{cell(a['after_wrong'])} | {seen(r)} | {held} | {cell(d2.get('before'))} | "
                    f"{cell(d2.get('after_true'))} | {cell(t7.get('before'))} | "
                    f"{cell(t7.get('after_true'))} |")
    return '\n'.join(rows) + '\n'


def seen(r: dict) -> str:
    """What the case's fits show ('-' when the error before lay inside its floor band)."""
    if r['all']['before']['place'] != 'above':
        return '-'
    return separation(r).replace('_', ' ')


def line(r: dict) -> str:
    """One case in one line: headline before -> after (floor band), mm."""
    a = r['all']

    def fig(key: str) -> str:
        if key not in a:
            return '-'
        f = a[key]
        how = '' if key == 'before' else f" ({state(f).replace('_', ' ')})"
        return (f"{f['value']:.2f} [{f['floor']['low']:.2f}-{f['floor']['high']:.2f}] "
                f"{f['place']}{how}")

    t7 = r.get('table7', {})
    t7s = (f" | T7 {t7['before']['value']:.1f} -> {t7['after_true']['value']:.1f} % "
           f"[{t7['after_true']['floor']['low']:.1f}-{t7['after_true']['floor']['high']:.1f}]"
           if 'after_true' in t7 else '')
    h = r['held_out']
    held = (f" | held-out {h['before']['value']:.2f} -> "
            f"{h.get('after_true', h['before'])['value']:.2f}")
    return (f"{r['case']:20s} s{r['seed']} {r['verdict']:19s} before {fig('before')}; "
            f"true {fig('after_true')}; wrong {r['wrong_fit']['candidate']} "
            f"{fig('after_wrong')}: {seen(r)}{held}{t7s}")


if __name__ == '__main__':
    main()
