"""How many markers can the field twin's cameras reconstruct, and when?

By default reads the truth of the bundled rendered recording (``bags/field_render_reduced_1ms``):
per frame and camera, each marker's visible fraction of its disc. With ``--run DIR`` it computes
the same visibility for a dempath_sim run folder seen through a rig (``--rig carriage|fixed``)
without rendering the images (:mod:`dempath_twin.render.coverage`), to compare placements on one
bed. A marker can be triangulated in a frame only when both cameras see at least half its disc;
its coverage is the share of the pass's frames in which both do, and ``markers_reconstructed``
counts the markers covered in at least 80 % of the frames (issue 26 asks for 13 of 15). This is
what the rig's placement allows, before detection; with ``--detected`` the count is taken
through the demo's own detection and reconstruction instead (the placement's count kept under
``visible``). Prints a line per marker and one JSON line last.

Usage: ``.venv/bin/python bench/marker_coverage.py [TRUTH_JSON] [--detected] [--run DIR
--rig NAME [--quick]] [--out JSON]``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from dempath_twin.render.coverage import Coverage, rig_coverage, truth_coverage

ROOT = Path(__file__).resolve().parents[1]
TRUTH = ROOT / 'bags/field_render_reduced_1ms.truth.json'


def from_run(run: Path, rig_name: str, quick: bool = False) -> Coverage:
    """Coverage of a run folder through a rig, at the bundled recording's settings (``quick``:
    no supersampling and one sub-frame per exposure, about 8x less work)."""
    from dataclasses import replace

    from dempath_twin.render.bed_source import load_bed
    from dempath_twin.render.camera_frame import Look
    from dempath_twin.render.recording import RecordingConfig
    from dempath_twin.rig import RIGS

    look = replace(Look(), blur_subframes=1, supersample=1) if quick else \
        replace(Look(), blur_subframes=2)
    config = RecordingConfig(look=look)
    return rig_coverage(load_bed(run, config.fps), RIGS[rig_name](), config)


def detected(truth_json: Path) -> dict[str, object]:
    """Markers reconstructed through the demo's path (own calibration from the recording's
    board segment, detection, tracking, the reconstructor's dlt_refined), over the frames in
    which each marker is on the surface."""
    import sys

    sys.path.insert(0, str(ROOT / 'bench'))
    from detect_track import node_path, read_frames

    truth = json.loads(truth_json.read_text())
    bag = truth_json.with_name(truth_json.name.removesuffix('.truth.json'))
    frames = read_frames(bag, truth['calibration_segment']['field_start_ns'],
                         [c['name'] for c in truth['cameras']])
    path = node_path(bag, frames, truth)
    return {'markers_reconstructed': path['markers_reconstructed'],
            'reconstructed': path['reconstructed'], 'share_3d': path['share_3d'],
            'traj_rms_mm': round(path['traj_rms_mm'], 3), 'points': path['points'],
            'wrong_numbers': path['wrong_numbers'],
            'through': "the demo's detection and reconstruction (bench/detect_track.py)"}


def main() -> None:
    """Print the per-marker coverage and one JSON line last."""
    p = argparse.ArgumentParser()
    p.add_argument('truth', nargs='?', type=Path, default=TRUTH)
    p.add_argument('--run', type=Path, help='dempath_sim run folder with bed snapshots')
    p.add_argument('--rig', default='carriage', choices=('carriage', 'fixed'))
    p.add_argument('--quick', action='store_true',
                   help='with --run: no supersampling, one sub-frame per exposure')
    p.add_argument('--out', type=Path)
    p.add_argument('--detected', action='store_true',
                   help="also through the demo's detection and reconstruction (the recording "
                        'beside TRUTH_JSON; bench/detect_track.py): markers_reconstructed is '
                        'then the markers with a 3D point in >= 80 %% of their on-surface frames')
    args = p.parse_args()
    cov = from_run(args.run, args.rig, args.quick) if args.run else truth_coverage(
        json.loads(args.truth.read_text()))
    out = cov.to_json()
    out['source'] = (f"{args.run} through the {args.rig} rig{' (quick)' if args.quick else ''}"
                     if args.run else str(args.truth))
    if args.detected and not args.run:
        out['visible'] = {k: out[k] for k in ('markers_reconstructed', 'reconstructed')}
        out.update(detected(args.truth))
    for m, row in out['per_marker'].items():
        print(f'marker {m:>2}: ' + '  '.join(f'{k} {v:.0%}' for k, v in row.items()))
    if args.out:
        args.out.write_text(json.dumps(out))
    print(json.dumps(out))


if __name__ == '__main__':
    main()
