"""Make ``bags/field_twin_<scene>``: the demo's synthetic field recording (the "measurement").

SYNTHETIC DATA. A DEM run of a shipped scene (``tiny`` today; ``reduced_1ms`` once it runs
through, see docs/demo.md) with a hidden physical setting (another packing seed, and an effect
the scene has off) plays the part of the real soil bin; its 15
marker trajectories are projected through the twin's true cameras (``paper_rig()``), resampled
to the cameras' 50 FPS and disturbed with the paper's clicking noise (2.36 px x, 2.75 px y), then
written as a rosbag2 MCAP bag: ``dempath_msgs/PixelPoints`` (SOURCE_CLICKED) on
``/cam_side/pixel_points`` and ``/cam_front/pixel_points``, and 960x540 JPEG previews of the
marker spheres on ``/<cam>/image_raw/compressed`` for Foxglove. Beside it:
``field_twin_<scene>.truth.json`` (the hidden setting, frames, noise, sizes) and
``field_twin_<scene>.truth.csv`` (the true trajectories in the field frame, t,marker,x,y,z).

Usage::

    .venv/bin/python bags/make_field_twin.py [--scene tiny] [--sim-dir DIR] [--out DIR]

``--sim-dir`` reuses the output folder of an earlier ``dempath simulate`` run with the hidden
setting (its ``markers.csv`` and ``summary.json``); without it the run is made here (minutes).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

from dempath.bagio import make_typestore, write_bag
from dempath_calib.rig import paper_rig
from dempath_recon import fieldtwin as ft
from dempath_sim.cli import simulate_main

HERE = Path(__file__).resolve().parent
HIDDEN = {'seed': 7, 'on': ['cohesion'], 'effects': {}}  # what the later diagnosis must find
NOISE_SEED = 2025


def simulate_hidden(scene: str, out: Path) -> Path:
    """Run ``scene`` with the hidden setting into ``out`` (``dempath simulate``)."""
    argv = [scene, '--out', str(out), '--seed', str(HIDDEN['seed']), '--quiet']
    argv += [a for name in HIDDEN['on'] for a in ('--on', name)]
    argv += [a for k, v in HIDDEN['effects'].items() for a in ('--effect', f'{k}={v}')]
    if simulate_main(argv) != 0:
        raise SystemExit(f'error: {scene}: the hidden run failed')
    return out


def main(argv: list[str]) -> int:
    """Write the bag, the truth JSON and the truth CSV; print their sizes."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument('--sim-dir', type=Path, help='output folder of the hidden dempath run')
    p.add_argument('--scene', default='tiny', help='shipped scene name or scene file')
    p.add_argument('--out', type=Path, help='bag to create (default bags/field_twin_<scene>)')
    args = p.parse_args(argv)
    args.out = args.out or HERE / f'field_twin_{Path(args.scene).stem}'
    with tempfile.TemporaryDirectory() as tmp:
        sim_dir = args.sim_dir or simulate_hidden(args.scene, Path(tmp) / 'sim')
        summary = json.loads((sim_dir / 'summary.json').read_text())
        scene_tracks = ft.read_marker_csv(sim_dir / 'markers.csv')
    config = ft.FieldTwinConfig(seed=NOISE_SEED)
    origin = ft.grid_origin(scene_tracks)
    tracks = ft.shift(ft.resample(scene_tracks, config.fps), origin)
    rig = paper_rig()
    true_uv = ft.project_tracks(rig.cameras, tracks.xyz)
    clicked = ft.click_noise(true_uv, config.sigma_px, np.random.default_rng(NOISE_SEED))
    if args.out.exists():
        shutil.rmtree(args.out)
    store = make_typestore()
    write_bag(args.out, ft.field_messages(tracks, rig.cameras, clicked, config, store.types),
              typestore=store)
    ft.write_truth_csv(args.out.with_name(args.out.name + '.truth.csv'), tracks)
    truth = {
        'synthetic': True,
        'what': 'field twin of the demo: DEM run with a hidden setting, seen by the twin rig',
        'scene': args.scene, 'run_id': summary.get('run_id'),
        'hidden': {'packing_seed': HIDDEN['seed'], 'effects_switched_on': HIDDEN['on'],
                   'effect_overrides': HIDDEN['effects'],
                   'effects': summary.get('effects')},
        'field_origin_in_scene_m': origin.tolist(),
        'frame': 'field = scene - field_origin_in_scene_m (X lateral, Y up, Z travel) [m]',
        'fps': config.fps, 'frames': len(tracks.times), 'start_ns': ft.START_NS,
        'click_noise_px': list(config.sigma_px), 'noise_seed': NOISE_SEED,
        'outside_image_points': ft.outside_image(rig.cameras, clicked),
        'cameras': rig.to_dict(), 'preview_scale': config.image_scale,
        'truth_csv': args.out.name + '.truth.csv',
    }
    args.out.with_name(args.out.name + '.truth.json').write_text(json.dumps(truth, indent=1))
    size = sum(f.stat().st_size for f in args.out.iterdir())
    print(f'{args.out}: {len(tracks.times)} frames, {size / 1e6:.2f} MB, '
          f'{truth["outside_image_points"]} clicks outside the images')
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
