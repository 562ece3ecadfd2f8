"""One LIGGGHTS-made case diagnosed both ways: against a library built on LIGGGHTS and on dempath.

A LIGGGHTS user's model is the scene run on LIGGGHTS; their measurement stand-in is a pass of
that scene on LIGGGHTS with one hidden change (on a case seed the libraries never used, from the
same settled bed dempath pours, 1.5 mm noise per axis). It is diagnosed with ``dempath diagnose
--backend liggghts`` (the signature library built on LIGGGHTS) and ``--backend dempath`` (the
library on dempath's engine), same design. Everything is cached under ``--root``. The last line
is one JSON object.

Usage: ``nice -n 10 .venv/bin/python bench/diagnose_backends.py [--scene tiny]
[--case tool_speed.speed_scale=1.5] [--candidates tool_speed,cohesion,rolling_resistance]``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from dempath_diagnose.cli import diagnose_main
from dempath_diagnose.library.cases import HiddenCase, make_case
from dempath_diagnose.library.simulator import load_scene, pass_travel_s
from dempath_diagnose.library.store import covering_duration


def main() -> None:
    """Build both libraries (cached), make the case, diagnose it both ways."""
    p = argparse.ArgumentParser()
    p.add_argument('--scene', default='tiny')
    p.add_argument('--root', type=Path, default=Path.home() / '.cache/dempath/bench-backends')
    p.add_argument('--seeds', default='1001,1002,1003')
    p.add_argument('--candidates', default='tool_speed,cohesion,rolling_resistance')
    p.add_argument('--case', default='tool_speed.speed_scale=1.5')
    p.add_argument('--case-seed', type=int, default=7)
    args = p.parse_args()
    scene = load_scene(args.scene)
    key, value = args.case.split('=')
    truth = key.split('.')[0]
    hidden = HiddenCase(f'{truth}_{value}', {key: float(value)}, truth, seed=args.case_seed)
    duration = covering_duration(pass_travel_s(scene, {}), 0.0)
    packings = args.root / 'packings'
    markers, force = make_case(scene, hidden, args.root / 'cases' / f'{hidden.name}_liggghts',
                               until_s=duration, cache_dir=packings, backend='liggghts')
    rows = []
    for backend in ('liggghts', 'dempath'):
        out = args.root / 'diag' / backend
        t0 = time.monotonic()
        code = diagnose_main(['--measured', str(markers), '--force', str(force),
                              '--scene', args.scene, '--out', str(out),
                              '--library-root', str(args.root / 'library'),
                              '--packing-cache', str(packings), '--seeds', args.seeds,
                              '--candidates', args.candidates, '--strengths', '1',
                              '--serial', '--backend', backend, '--budget', '0'])
        wall = time.monotonic() - t0
        if code != 0:
            rows.append({'backend': backend, 'error': code})
            continue
        data = json.loads((out / 'diagnosis.json').read_text())
        top = data['ranking'][0]
        rows.append({'backend': backend, 'verdict': data['verdict'], 'top': top['effect'],
                     'p': round(top['probability'], 3),
                     'fitted': round(top['strength']['value'], 4),
                     'sd': round(top['strength']['uncertainty'], 4),
                     'nothing': round(data['baseline']['probability'], 3),
                     'baseline_implausibility': round(data['baseline']['implausibility'], 2),
                     'simulations': data['simulations'], 'wall_s': round(wall, 1)})
        print(json.dumps(rows[-1]), flush=True)
    print(json.dumps({'scene': args.scene, 'case': hidden.name, 'truth': truth,
                      'case_engine': 'liggghts', 'seeds': args.seeds,
                      'candidates': args.candidates, 'results': rows}))


if __name__ == '__main__':
    main()
