"""Make ``bags/field_render_reduced_1ms``: the demo's rendered field recording, two cached steps.

SYNTHETIC DATA. Step 1 runs the demo's hidden ``reduced_1ms`` run (the setting of
``dempath_twin.field.demo_bag.hidden_setting``: seed 7, cohesion 1e5 J/m^3) with bed snapshots
at twice the cameras' frame rate, into ``--run-dir`` (skipped when that folder already holds the
run: the slow part, about 20 min on a loaded 2-core machine). Step 2 renders it through the
twin's carriage rig (``dempath_twin.rig.carriage_rig``: the paper's side and front GoPros on the
carriage frame, looking down at the 3 x 5 marker grid) with the bundled bag's settings
(12 calibration views, JPEG 85, 2 blur sub-frames), as ``dempath twin render`` does.

Usage::

    nice -n 10 .venv/bin/python bags/make_field_render.py [--run-dir DIR] [--out BAG]
        [--rig carriage|fixed] [--run-only]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENE = 'reduced_1ms'


def run_dir_for(path: Path) -> Path:
    """Run the hidden setting into ``path`` unless it already holds the run (the cache)."""
    from dempath_sim.scene import resolve_scene
    from dempath_twin.field.demo_bag import hidden_setting
    from dempath_twin.render.bed_source import run_for_recording

    if (path / 'result.npz').is_file() and (path / 'bed_radii.npz').is_file():
        return path
    hidden = hidden_setting(SCENE)
    scene = resolve_scene(SCENE).with_overrides(hidden['effects'], on=hidden['on'],
                                                seed=hidden['seed'])
    return run_for_recording(scene, path)


def main(argv: list[str]) -> int:
    """Both steps; the render's options are the bundled bag's."""
    from dempath_twin.render.bag import render_main

    p = argparse.ArgumentParser(prog='make_field_render.py')
    p.add_argument('--run-dir', type=Path, default=Path('out/field_render_run'))
    p.add_argument('--out', type=Path, default=HERE / f'field_render_{SCENE}')
    p.add_argument('--rig', default='carriage', choices=('carriage', 'fixed'))
    p.add_argument('--run-only', action='store_true', help='step 1 only')
    args = p.parse_args(argv)
    run = run_dir_for(args.run_dir)
    if args.run_only:
        print(f'{run}: the hidden run')
        return 0
    return render_main([str(run), '--out', str(args.out), '--calib-views', '12',
                        '--quality', '85', '--blur-subframes', '2', '--rig', args.rig])


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
