"""Rebuild the MLP that ships with dempath_recon from the twin's calibration point set.

The twin (``recording.synthetic_point_set``: 94,939 board corners seen through ``paper_rig``, 0.2
px corner noise, seed 0) is split as in the paper (4,149 held-out rows); the default
:class:`~dempath_recon.methods.mlp.MLPReconstructor` trains on the rest and is saved as float16
into ``dempath_recon/data`` (see :mod:`dempath_recon.methods.shipped`). About 2-3 minutes on two
idle cores::

    python -m dempath_twin.board.shipped_mlp [--out DIR] [--threads 2]
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from dempath_recon.methods.evaluation import error_metrics, holdout_split
from dempath_recon.methods.mlp import MLPReconstructor
from dempath_recon.methods.shipped import DATA_DIR, RIG_NOTE, SHIPPED_NAME
from dempath_twin.board.recording import synthetic_point_set

FloatArray = NDArray[np.float64]
TWIN_SAMPLES, TWIN_NOISE_PX, TWIN_SEED = 94_939, 0.2, 0  # the paper's point-set size


def twin_split(seed: int = TWIN_SEED) -> tuple[tuple[FloatArray, FloatArray],
                                               tuple[FloatArray, FloatArray]]:
    """The twin's point set split as in the paper: ((X, y) training, (X, y) 4,149 held out)."""
    ps = synthetic_point_set(TWIN_SAMPLES, noise_px=TWIN_NOISE_PX, seed=seed)
    train, test = holdout_split(len(ps), seed)
    return (ps.pixels[train], ps.xyz[train]), (ps.pixels[test], ps.xyz[test])


def build_shipped(out_dir: str | Path = DATA_DIR, seed: int = TWIN_SEED) -> dict[str, Any]:
    """Train the default MLP on the twin's training rows, save it as float16, score the file.

    Returns:
        The provenance written to ``<out_dir>/mlp_twin_rig.json``: data, hyperparameters,
        training wall and CPU time, torch threads, load average, and the held-out figures of the
        in-memory network and of the saved file as loaded.
    """
    (px, xyz), (px_test, xyz_test) = twin_split(seed)
    load_before = os.getloadavg()[0]
    est = MLPReconstructor(random_state=seed, device='cpu').fit(px, xyz)
    out = Path(out_dir)
    path = est.save(out / f'{SHIPPED_NAME}.pt', weights='float16')
    loaded = MLPReconstructor.load(path, device='cpu')
    info = {'file': path.name, 'bytes': path.stat().st_size, 'weights': 'float16',
            'note': RIG_NOTE, 'rebuild': 'python -m dempath_twin.board.shipped_mlp',
            'data': {'source': 'dempath_twin.board.recording.synthetic_point_set',
                     'rig': 'paper_rig',
                     'samples': TWIN_SAMPLES, 'corner_noise_px': TWIN_NOISE_PX, 'seed': seed,
                     'train_rows': len(px), 'held_out_rows': len(px_test)},
            'params': est.get_params(), 'epochs_run': est.n_iter_,
            'train_s': est.fit_time_s_, 'train_cpu_s': est.fit_cpu_s_,
            'epoch_s': est.epoch_time_s_, 'torch_threads': torch.get_num_threads(),
            'load_avg_1min': [load_before, os.getloadavg()[0]],
            'held_out_in_memory': error_metrics(est.predict(px_test), xyz_test),
            'held_out_as_loaded': error_metrics(loaded.predict(px_test), xyz_test),
            'built': time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime()),
            'torch': torch.__version__}
    (out / f'{SHIPPED_NAME}.json').write_text(json.dumps(info, indent=1) + '\n')
    return info


def main(argv: list[str] | None = None) -> int:
    """``python -m dempath_twin.board.shipped_mlp``: rebuild the shipped network; prints its
    figures."""
    parser = argparse.ArgumentParser(prog='python -m dempath_twin.board.shipped_mlp',
                                     description=main.__doc__)
    parser.add_argument('--out', default=str(DATA_DIR), help='folder for the .pt and .json')
    parser.add_argument('--threads', type=int, default=2, help='torch CPU threads')
    parser.add_argument('--seed', type=int, default=TWIN_SEED)
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    logging.basicConfig(level=logging.INFO, stream=sys.stderr, format='%(message)s')
    info = build_shipped(args.out, args.seed)
    loaded = info['held_out_as_loaded']
    print(f"{info['file']}: {info['bytes'] / 1e6:.1f} MB, trained {info['train_s']:.0f} s "
          f"({info['epochs_run']} epochs); as loaded: mean {loaded['mean_mm']:.3f} mm, "
          f"max {loaded['max_mm']:.3f} mm on {info['data']['held_out_rows']} held-out rows")
    return 0


if __name__ == '__main__':
    sys.exit(main())
