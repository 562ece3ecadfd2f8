"""How many markers can the bundled field twin's cameras reconstruct, and when?

Reads the truth of a rendered field recording (default: the bundled
``bags/field_render_reduced_1ms``): per frame and camera, each marker's visible fraction of its
disc. A marker can be triangulated in a frame only when both cameras see it (at least half its
disc visible: the detector's recall on such markers is 99 %, bench/detect_track.py), so its
coverage is the share of the pass's frames in which both cameras do. ``markers_reconstructed``
counts the markers covered in at least 80 % of the frames (issue 26 asks for 13 of 15). This is
what the rig's camera placement allows, before detection; the demo's own count of
reconstructed markers is in its report. Prints a line per marker and one JSON line last.

Usage: ``.venv/bin/python bench/marker_coverage.py [TRUTH_JSON] [--out JSON]``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TRUTH = ROOT / 'bags/field_render_reduced_1ms.truth.json'
VISIBLE = 0.5  # visible fraction of a marker's disc for a detection
COVERED = 0.8  # share of the frames a reconstructed marker needs


def coverage(truth: dict) -> dict:
    """Per marker: share of frames seen by each camera and by both."""
    by_cam: dict[str, list[np.ndarray]] = {}
    for frame in truth['frames']:
        by_cam.setdefault(frame['camera'], []).append(np.asarray(frame['visible']) >= VISIBLE)
    cams = sorted(by_cam)
    n = min(len(v) for v in by_cam.values())
    seen = {c: np.array(by_cam[c][:n]) for c in cams}  # (frames, markers)
    both = np.logical_and.reduce([seen[c] for c in cams])
    markers = [int(m) for m in truth['marker_ids']]
    rows = {str(m): {**{c: round(float(seen[c][:, j].mean()), 3) for c in cams},
                     'both': round(float(both[:, j].mean()), 3)}
            for j, m in enumerate(markers)}
    good = [m for m in markers if rows[str(m)]['both'] >= COVERED]
    return {'frames': n, 'markers': len(markers), 'markers_reconstructed': len(good),
            'reconstructed': good, 'per_marker': rows}


def main() -> None:
    """Print the per-marker coverage and one JSON line last."""
    p = argparse.ArgumentParser()
    p.add_argument('truth', nargs='?', type=Path, default=TRUTH)
    p.add_argument('--out', type=Path)
    args = p.parse_args()
    out = coverage(json.loads(args.truth.read_text()))
    for m, row in out['per_marker'].items():
        print(f'marker {m:>2}: ' + '  '.join(f'{k} {v:.0%}' for k, v in row.items()))
    if args.out:
        args.out.write_text(json.dumps(out))
    print(json.dumps(out))


if __name__ == '__main__':
    main()
