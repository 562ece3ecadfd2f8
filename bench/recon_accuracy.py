"""Benchmark of pixel-to-3D reconstruction on the digital twin (issue #5 targets).

A paper-size calibration point set (94,939 board-corner samples, 0.2 px corner noise) comes from
``dempath_twin.board.recording.synthetic_point_set`` (true board corners projected through
``paper_rig``); 4,149 rows are held out as in the paper. Every method is fitted on the other 90,790
rows with no access to the true cameras (the triangulation methods resect them from the training
rows), then scored on the held-out rows: mean / SD / max 3D error [mm], R2 per axis, training wall
time and throughput. The paper's network is trained with dempath's recipe (standardised, AdamW,
one-cycle, 10 epochs; ``--mlp-recipe paper`` for the published one, ``--mlp-epochs`` to change the
epochs); its figures (and those of the shipped float16 file as loaded) are in ``mlp`` of the JSON
line.
Clicking noise of 2.36 / 2.75 px (the paper's) is then propagated and the coverage of the
published 1-sigma is checked.

Targets: mean <= 0.5 mm and max <= 3 mm for the best method; the fastest method meeting them
trains in < 120 s; throughput >= 100,000 point pairs/s. The last line printed is one JSON object.

Usage: ``python bench/recon_accuracy.py [--mlp-recipe dempath|paper] [--mlp-epochs N]
[--mlp-batch B] [--mlp-lr LR]
[--torch-threads T] [--out DIR]`` (2 threads by default; on a machine loaded by other
processes thread hand-offs stall, so the JSON gives the load, CPU time and time per epoch too).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import torch

from dempath_calib.camera import CameraModel
from dempath_recon.methods.evaluation import (
    PAPER_TABLE5,
    best_method,
    evaluate,
    fastest_meeting,
    holdout_split,
    write_report,
)
from dempath_recon.methods.mlp import PAPER_RECIPE
from dempath_recon.methods.registry import make_reconstructor
from dempath_recon.methods.triangulate import DLTTriangulator
from dempath_recon.methods.uncertainty import CLICK_SIGMA_PX, coverage, propagate
from dempath_twin.board.recording import synthetic_point_set
from dempath_twin.rig import paper_rig

N_SAMPLES = 94_939  # the paper's point set size
TARGET_MEAN_MM, TARGET_MAX_MM, TARGET_TRAIN_S, TARGET_PPS = 0.5, 3.0, 120.0, 100_000


def clicked_uncertainty(estimator: Any, xyz: np.ndarray, seed: int) -> dict[str, Any]:
    """Project true points, add the paper's clicking noise, reconstruct, check the 1-sigma."""
    rng = np.random.default_rng(seed)
    pixels = np.hstack([c.project(xyz) for c in paper_rig().cameras])
    pixels = pixels + rng.normal(size=pixels.shape) * np.tile(CLICK_SIGMA_PX, 2)
    pred = estimator.predict(pixels)
    cov = propagate(estimator, pixels)
    err = np.linalg.norm(pred - xyz, axis=1) * 1e3
    sigma = np.sqrt(np.diagonal(cov, axis1=1, axis2=2)) * 1e3
    cover = coverage(pred - xyz, cov)
    return {'click_sigma_px': list(CLICK_SIGMA_PX), 'mean_mm': float(np.nanmean(err)),
            'max_mm': float(np.nanmax(err)), 'sd_mm': float(np.nanstd(err, ddof=1)),
            'mean_sigma_mm': np.nanmean(sigma, axis=0).tolist(),
            'coverage_per_axis': cover['per_axis'], 'coverage_mahalanobis': cover['mahalanobis']}


def biased_calibration(tr: tuple[np.ndarray, np.ndarray], te: tuple[np.ndarray, np.ndarray],
                       seed: int) -> dict[str, Any]:
    """DLT vs residual model when the calibration is off (front fx, fy +1 %, k1 +0.02)."""
    rig = paper_rig()
    front = rig.front
    k, dist = front.K.copy(), front.dist.copy()
    k[0, 0] *= 1.01
    k[1, 1] *= 1.01
    dist[0] += 0.02
    cams = (rig.side, CameraModel(front.name, front.width, front.height, k, dist, front.R,
                                  front.t))
    out: dict[str, Any] = {'perturbation': 'front camera fx, fy +1 %, k1 +0.02'}
    for name in ('dlt', 'dlt_residual'):
        params = {'random_state': seed, 'device': 'cpu'} if name == 'dlt_residual' else {}
        row, _ = evaluate(name, make_reconstructor(name, **params), tr, te, calibration=cams)
        out[name] = {'mean_mm': row.mean_mm, 'max_mm': row.max_mm, 'train_s': row.train_s}
    return out


def score_methods(args: argparse.Namespace, tr: tuple[np.ndarray, np.ndarray],
                  te: tuple[np.ndarray, np.ndarray]) -> tuple[list[Any], dict[str, Any],
                                                              dict[str, Any]]:
    """Fit every method not skipped on ``tr`` and score it on ``te``."""
    rows, errors, fitted = [], {}, {}
    mlp_params = {**(PAPER_RECIPE if args.mlp_recipe == 'paper' else {}),
                  'random_state': args.seed, 'device': 'cpu'}
    if args.mlp_epochs:
        mlp_params['epochs'] = args.mlp_epochs
    if args.mlp_batch:
        mlp_params['batch_size'] = args.mlp_batch
    if args.mlp_lr:
        mlp_params['learning_rate'] = args.mlp_lr
    plan = [('dlt', {}, 'cameras resected from the training rows; linear, depth re-weighted'),
            ('dlt_refined', {}, 'as dlt + 2 Gauss-Newton steps on the pixel reprojection error'),
            ('dlt_residual', {'random_state': args.seed, 'device': 'cpu'},
             'dlt + (64, 64) network on its residual'),
            ('mlp', mlp_params, f"the paper's 2048-1024-512 network, {args.mlp_recipe} recipe")]
    for name, params, notes in plan:
        if name in args.skip:
            continue
        est = make_reconstructor(name, **params)
        row, err = evaluate(name, est, tr, te, notes=notes)
        rows.append(row)
        errors[name] = err
        fitted[name] = est
    return rows, errors, fitted


def mlp_figures(m: Any, row: Any, te: tuple[np.ndarray, np.ndarray],
                args: argparse.Namespace) -> dict[str, Any]:
    """The trained MLP's figures, and the shipped float16 file's as loaded (same split only)."""
    out = {'recipe': args.mlp_recipe, 'mean_mm': row.mean_mm, 'sd_mm': row.sd_mm,
           'max_mm': row.max_mm, 'r2': row.r2, 'train_s': m.fit_time_s_,
           'train_cpu_s': m.fit_cpu_s_, 'epochs': m.n_iter_, 'epoch_s': m.epoch_time_s_,
           'epoch_cpu_s': m.epoch_cpu_s_, 'load_avg_at_epoch_ends': m.epoch_load_,
           'load_avg_mean': float(np.mean(m.epoch_load_)),
           'points_per_s': row.points_per_s, 'torch_threads': torch.get_num_threads()}
    if args.seed == 0 and args.noise_px == 0.2:  # the shipped file's data and split
        from dempath_recon.methods.evaluation import error_metrics
        from dempath_recon.methods.shipped import load_shipped_mlp

        shipped = error_metrics(load_shipped_mlp().predict(te[0]), te[1])
        out['shipped_as_loaded'] = {k: shipped[k] for k in ('mean_mm', 'sd_mm', 'max_mm', 'r2')}
    return out


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Fit and score every method; return the JSON summary."""
    t0 = time.perf_counter()
    ps = synthetic_point_set(N_SAMPLES, noise_px=args.noise_px, seed=args.seed)
    gen_s = time.perf_counter() - t0
    train, test = holdout_split(len(ps), args.seed)
    tr, te = (ps.pixels[train], ps.xyz[train]), (ps.pixels[test], ps.xyz[test])
    rows, errors, fitted = score_methods(args, tr, te)
    oracle = DLTTriangulator(refine=False).fit(calibration=paper_rig())
    oracle_err = np.linalg.norm(oracle.predict(te[0]) - te[1], axis=1) * 1e3
    best = best_method(rows)
    summary: dict[str, Any] = {
        'samples': len(ps), 'train_rows': len(train), 'test_rows': len(test),
        'corner_noise_px': args.noise_px, 'point_set_s': gen_s,
        'methods': [{k: v for k, v in asdict(r).items()} for r in rows],
        'best': best, 'fastest_meeting_target': fastest_meeting(rows, TARGET_MEAN_MM,
                                                                TARGET_MAX_MM),
        'targets': {'mean_mm': TARGET_MEAN_MM, 'max_mm': TARGET_MAX_MM,
                    'train_s': TARGET_TRAIN_S, 'points_per_s': TARGET_PPS},
        'oracle_true_cameras_dlt': {'mean_mm': float(oracle_err.mean()),
                                    'max_mm': float(oracle_err.max())},
        'paper_table5': PAPER_TABLE5,
        'machine': {'cpus': os.cpu_count(), 'torch_threads': torch.get_num_threads(),
                    'cuda': torch.cuda.is_available(), 'load_avg_1min': os.getloadavg()[0]},
    }
    if 'mlp' in fitted:
        summary['mlp'] = mlp_figures(fitted['mlp'], next(r for r in rows if r.name == 'mlp'),
                                     te, args)
    if best:
        summary['uncertainty'] = {'method': best,
                                  **clicked_uncertainty(fitted[best], te[1], args.seed + 1)}
    if 'biased' not in args.skip:
        summary['biased_calibration'] = biased_calibration(tr, te, args.seed)
    if args.out:
        write_report(args.out, rows, errors,
                     f'Digital twin, {len(ps):,} samples, {args.noise_px} px corner noise, '
                     f'{len(test):,} held out. Generated by bench/recon_accuracy.py.')
        summary['report_dir'] = str(Path(args.out).resolve())
    return summary


def main() -> int:
    """Parse options, run, print a readable table and the JSON line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--mlp-recipe', choices=('dempath', 'paper'), default='dempath')
    parser.add_argument('--mlp-epochs', type=int, default=0, help="MLP epochs (0: the recipe's)")
    parser.add_argument('--mlp-batch', type=int, default=0, help="MLP batch (0: the recipe's)")
    parser.add_argument('--mlp-lr', type=float, default=0.0,
                        help="MLP (peak) learning rate (0: the recipe's)")
    parser.add_argument('--noise-px', type=float, default=0.2, help='corner noise [px]')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--skip', default='', help='comma-separated methods to leave out')
    parser.add_argument('--out', default='', help='folder for report.md / histogram PNG')
    parser.add_argument('--torch-threads', type=int, default=2, help='torch CPU threads')
    args = parser.parse_args()
    torch.set_num_threads(args.torch_threads)
    args.skip = set(filter(None, args.skip.split(',')))
    logging.basicConfig(level=logging.INFO, stream=sys.stderr, format='%(message)s')
    summary = run(args)
    for m in summary['methods']:
        print(f"{m['name']:>13}: mean {m['mean_mm']:.3f} mm, max {m['max_mm']:.3f} mm, "
              f"train {m['train_s']:.1f} s, {m['points_per_s']:,.0f} points/s",
              file=sys.stderr)
    print(json.dumps(summary))
    return 0


if __name__ == '__main__':
    sys.exit(main())
