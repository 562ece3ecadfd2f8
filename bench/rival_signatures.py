"""Do two effects move a scene the same way? Draft and marker statistics per effect, by seed.

Issue 32 asks for a case with two rivals of similar signature (cohesion against rolling
resistance on a scene where both raise the draft). This bench runs a scene's baseline and each
named change on the same packing seeds (the library's set-up: one bed per seed, re-settled with
the run's physics) and prints, per change, the draft (mean -Fz while the tool moves [N]) and the
markers' mean displacement at the end of the recording [mm] (on the tool's axis: vertical and
forward; beside it: outward and vertical), each as the mean over seeds with the paired
difference to the baseline and that difference over the seed spread of the baseline (sd of the
baseline over seeds). Each run's figures are cached under ``--root``; an interrupted bench
resumes. The last line is one JSON object.

Usage: ``.venv/bin/python bench/rival_signatures.py --scene tiny_rivals
--change coh1e5=cohesion.energy_density_j_m3:1e5
--change roll052=rolling_resistance.coefficient:0.52``
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from dempath_diagnose.library.cases import HiddenCase, make_case
from dempath_diagnose.library.simulator import (
    load_scene,
    pass_travel_s,
    physics_key,
    tool_geometry,
)
from dempath_diagnose.library.store import covering_duration

STATS = ('draft_n', 'axis_vertical_mm', 'axis_forward_mm', 'side_outward_mm',
         'side_vertical_mm')


def parse_change(text: str) -> tuple[str, dict[str, float]]:
    """``name=effect.parameter:value[,effect.parameter:value]`` -> (name, overrides)."""
    name, _, rest = text.partition('=')
    if not name or not rest:
        raise SystemExit(f'--change {text!r}: expected name=effect.parameter:value')
    out = {}
    for part in rest.split(','):
        key, _, value = part.partition(':')
        try:
            out[key] = float(value)
        except ValueError:
            raise SystemExit(f'--change {text!r}: {value!r} is not a number') from None
    return name, out


def run_figures(scene: Any, seed: int, overrides: dict[str, float], folder: Path,
                until_s: float, packings: Path) -> dict[str, float]:
    """The draft and marker statistics of one noise-free pass (cached in ``folder``)."""
    done = folder / 'figures.json'
    if done.is_file():
        return dict(json.loads(done.read_text()))
    t0 = time.monotonic()
    case = HiddenCase(folder.name, overrides, seed=seed)
    markers, force = make_case(scene, case, folder, until_s=until_s, cache_dir=packings,
                               noise_m=0.0)
    f = np.loadtxt(force, delimiter=',', skiprows=1)
    m = np.loadtxt(markers, delimiter=',', skiprows=1)
    travel = pass_travel_s(scene, overrides)
    moving = (f[:, 0] > 0.1 * travel) & (f[:, 0] <= travel)
    x_axis, half, _ = tool_geometry(scene)
    first, last = {}, {}
    for _t, n, *xyz in m:
        first.setdefault(int(n), np.array(xyz))
        last[int(n)] = np.array(xyz)
    numbers = sorted(first)
    d = np.array([last[n] - first[n] for n in numbers]) * 1e3
    off = np.array([first[n][0] - x_axis for n in numbers])
    axis, side = np.abs(off) <= half, np.abs(off) > half
    out = {'draft_n': float(np.mean(-f[moving, 3])),
           'axis_vertical_mm': float(d[axis, 1].mean()),
           'axis_forward_mm': float(d[axis, 2].mean()),
           'side_outward_mm': float((d[side, 0] * np.sign(off[side])).mean()),
           'side_vertical_mm': float(d[side, 1].mean()),
           'wall_s': time.monotonic() - t0}
    done.write_text(json.dumps(out))
    return out


def compare(runs: dict[str, list[dict[str, float]]]) -> dict[str, Any]:
    """Per change: mean over seeds, paired difference to the baseline and it over the spread."""
    base = {s: np.array([r[s] for r in runs['baseline']]) for s in STATS}
    out: dict[str, Any] = {}
    for name, rows in runs.items():
        stats = {}
        for s in STATS:
            v = np.array([r[s] for r in rows])
            diff = v - base[s]
            spread = float(base[s].std(ddof=1)) if len(v) > 1 else float('nan')
            stats[s] = {'mean': round(float(v.mean()), 3),
                        'diff': round(float(diff.mean()), 3),
                        'diff_sd': round(float(diff.std(ddof=1)), 3) if len(v) > 1 else None,
                        'diff_over_spread': round(float(diff.mean()) / spread, 2)
                        if spread > 0 else None}
        out[name] = stats
    return out


def main() -> None:
    """Run the baseline and each change on every seed; print a table and one JSON line last."""
    p = argparse.ArgumentParser()
    p.add_argument('--scene', default='tiny_rivals')
    p.add_argument('--seeds', default='1001,1002,1003')
    p.add_argument('--change', action='append', default=[],
                   help='name=effect.parameter:value (repeatable)')
    p.add_argument('--root', type=Path, default=Path.home() / '.cache/dempath/rivals')
    args = p.parse_args()
    scene = load_scene(args.scene)
    changes = dict([('baseline', {})] + [parse_change(c) for c in args.change])
    until = covering_duration(pass_travel_s(scene, {}), 0.0)
    root = args.root / physics_key(scene)
    runs: dict[str, list[dict[str, float]]] = {}
    for seed in (int(s) for s in args.seeds.split(',')):
        for name, overrides in changes.items():
            fig = run_figures(scene, seed, overrides, root / f'{name}-{seed}', until,
                              args.root / 'packings')
            runs.setdefault(name, []).append(fig)
            print(json.dumps({'change': name, 'seed': seed,
                              **{k: round(v, 3) for k, v in fig.items()}}), flush=True)
    table = compare(runs)
    for name, stats in table.items():
        print(f'{name:>14} ' + ' '.join(
            f'{s}={v["mean"]:.2f} ({v["diff"]:+.2f}, {v["diff_over_spread"]} sd)'
            for s, v in stats.items()), flush=True)
    print(json.dumps({'scene': scene.name, 'seeds': args.seeds, 'changes': changes,
                      'figures': table}))


if __name__ == '__main__':
    main()
