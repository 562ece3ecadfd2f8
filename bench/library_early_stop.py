"""Could a library's runs end earlier? Their records frozen from a time T on, against the seed
spread of each model (issue 30: runs that end when the markers' statistics stop changing).

For every model of a built or packed library (its runs on every seed) and every frame time T
after the tool stops, each record is frozen from T on (the positions of the frame at T repeated:
what a run ended at T would record) and the diagnosis's group statistics (the scene's marker grid,
``model_statistics`` with the force) are computed both ways. Printed per T: the largest change of
any statistic in seed spreads of its model (the standard deviation over the library's seeds),
with the model and statistic. Last line: one JSON object.

    .venv/bin/python bench/library_early_stop.py \\
        --library src/dempath_diagnose/dempath_diagnose/data/libraries/reduced_1ms_library.npz
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from dempath_diagnose.decision.statistics import build_layout, model_statistics
from dempath_diagnose.library.simulator import load_scene, tool_geometry
from dempath_diagnose.library.store import Library
from dempath_diagnose.records import PassRecord

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sleep_effect import marker_starts


def frozen(rec: PassRecord, k: int) -> PassRecord:
    """``rec`` with every frame from ``k`` on equal to frame ``k``."""
    pos = rec.positions.copy()
    pos[k:] = pos[k]
    return replace(rec, positions=pos)


def main() -> None:
    """Print a row per frame time after the stop and the JSON line."""
    p = argparse.ArgumentParser()
    p.add_argument('--library', type=Path, required=True, help='library folder or packed file')
    p.add_argument('--scene', default='reduced_1ms')
    args = p.parse_args()
    lib = Library.load(args.library)
    scene = load_scene(args.scene)
    tool_x, half, cube = tool_geometry(scene)
    models: dict[str, list[PassRecord]] = {}
    for r in lib.runs:
        models.setdefault(r.label, []).append(lib.records[r.filename])
    first = models['baseline'][0]
    numbers, starts = marker_starts(scene, first)
    end, stop = float(first.times[-1]), float(first.meta['tool_stop_s'])
    layout = build_layout(numbers, starts, tool_x, half, end, stop)
    names = layout.names(True)
    rows = []
    for k in range(len(first.times) - 2, 0, -1):
        t = float(first.times[k])
        if t < stop - 1e-9:
            break
        worst = (0.0, '', '')
        for label, recs in models.items():
            if float(recs[0].meta['tool_stop_s']) > t or len(recs) < 2:
                continue
            full = np.array([model_statistics(r, layout, cube, True).vector for r in recs])
            cut = np.array([model_statistics(frozen(r, k), layout, cube, True).vector
                            for r in recs])
            spread = full.std(axis=0, ddof=1)
            ratio = np.abs(cut - full).max(axis=0) / np.where(spread > 0, spread, np.inf)
            j = int(np.nanargmax(ratio))
            if ratio[j] > worst[0]:
                worst = (float(ratio[j]), label, names[j])
        rows.append({'t_s': round(t, 3), 'followed_left_s': round(end - t, 3),
                     'largest_change_seed_spreads': round(worst[0], 3), 'model': worst[1],
                     'statistic': worst[2]})
        print(json.dumps(rows[-1]), flush=True)
    print(json.dumps({'library': str(args.library), 'tool_stop_s': stop, 'end_s': end,
                      'rows': rows}))


if __name__ == '__main__':
    main()
