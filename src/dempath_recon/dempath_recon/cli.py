"""Offline commands: ``dempath recon-train``, ``dempath reconstruct``, ``dempath recon-report``.

Each is ``def x_main(argv: list[str]) -> int``: bad input gives one ``error: <input>: <problem>``
line and 1; success 0.
"""

from __future__ import annotations

import argparse
import csv
import logging
import sys
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath.errors import DempathError
from dempath_recon.errors import ModelFileError, ReconstructionError
from dempath_recon.methods.evaluation import evaluate, holdout_split, write_report
from dempath_recon.methods.registry import (
    METHODS,
    learned_class,
    load_calibration,
    load_reconstructor,
    make_reconstructor,
)
from dempath_recon.methods.uncertainty import CLICK_SIGMA_PX, propagate, sigma_from_covariance

logger = logging.getLogger(__name__)
PIXEL_COLUMNS = ('xs', 'ys', 'xf', 'yf')


def _fail(err: Exception) -> int:
    print('error: ' + ' '.join(str(err).split()), file=sys.stderr)
    return 1


def _load_points(path: str) -> Any:
    """A dempath_calib point set (.npz or .csv), errors as ModelFileError."""
    from dempath_calib.errors import CalibrationFileError
    from dempath_calib.pointset import load_point_set

    try:
        return load_point_set(path)
    except CalibrationFileError as err:
        raise ModelFileError(' '.join(str(err).split())) from err


def _hidden(text: str) -> tuple[int, ...]:
    return tuple(int(v) for v in text.split(',') if v)


def _learned_params(args: argparse.Namespace, method: str) -> dict[str, Any]:
    params: dict[str, Any] = {'random_state': args.seed, 'device': args.device}
    if method == 'mlp':
        if args.mlp_recipe == 'paper':
            learned_class(method)  # torch is there, or one clear line
            from dempath_recon.methods.mlp import PAPER_RECIPE

            params.update(PAPER_RECIPE)
        params['hidden_sizes'] = _hidden(args.mlp_hidden)
        if args.mlp_epochs is not None:
            params['epochs'] = args.mlp_epochs
    return params if method in ('mlp', 'dlt_residual') else {}


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--calibration', default='', help='stereo calibration YAML')
    parser.add_argument('--seed', type=int, default=0, help='random seed')
    parser.add_argument('--device', default='cpu', help='torch device: cpu, cuda, auto')
    parser.add_argument('--mlp-recipe', choices=('dempath', 'paper'), default='dempath',
                        help="training of the MLP: dempath's (standardised, AdamW, one-cycle, "
                             "10 epochs) or the paper's (min-max, dropout, Adam, 60 epochs)")
    parser.add_argument('--mlp-epochs', type=int, default=None,
                        help="epochs of the MLP (default: the recipe's, 12 or 60)")
    parser.add_argument('--mlp-hidden', default='2048,1024,512', help='hidden layer sizes')


def train_main(argv: list[str]) -> int:
    """``dempath recon-train POINTS --method M --out FILE``: fit a method on a point set."""
    parser = argparse.ArgumentParser(prog='dempath recon-train', description=train_main.__doc__)
    parser.add_argument('points', help='calibration point set (.npz or .csv, dempath_calib)')
    parser.add_argument('--method', choices=METHODS, default='dlt_residual')
    parser.add_argument('--out', required=True, help='model file (.pt) or calibration (.yaml)')
    parser.add_argument('--weights', choices=('float32', 'float16'), default='float32',
                        help='precision of the saved MLP weights (float16: half the size)')
    _common(parser)
    args = parser.parse_args(argv)
    try:
        ps = _load_points(args.points)
        calib = load_calibration(args.calibration) if args.calibration else None
        est = make_reconstructor(args.method, **_learned_params(args, args.method))
        est.fit(ps.pixels, ps.xyz, calibration=calib)
        if args.method == 'mlp':
            est.save(args.out, weights=args.weights)
        elif hasattr(est, 'save'):
            est.save(args.out)
        else:
            _save_cameras(est.cameras_, args.out)
    except (DempathError, ValueError, OSError) as err:
        return _fail(err)
    print(f'{args.method}: trained on {len(ps)} samples -> {args.out}')
    return 0


def _save_cameras(cams: Any, path: str) -> None:
    from dempath_calib.camera import StereoCalibration

    StereoCalibration(cams[0], cams[1], {'source': 'dempath recon-train (resection)'}).save(path)


def _read_pixels_csv(path: str) -> tuple[list[dict[str, str]], NDArray[np.float64]]:
    try:
        with open(path, newline='') as fh:
            rows = list(csv.DictReader(fh))
    except OSError as err:
        msg = f'{path!r}: cannot read pixel CSV ({err.strerror})'
        raise ReconstructionError(msg) from err
    if not rows or any(c not in rows[0] for c in PIXEL_COLUMNS):
        msg = f'{path!r}: expected a CSV with columns {",".join(PIXEL_COLUMNS)}'
        raise ReconstructionError(msg)
    try:
        pixels = np.array([[float(r[c]) for c in PIXEL_COLUMNS] for r in rows])
    except ValueError as err:
        msg = f'{path!r}: non-numeric pixel value ({err})'
        raise ReconstructionError(msg) from err
    return rows, pixels


def reconstruct_main(argv: list[str]) -> int:
    """``dempath reconstruct PIXELS.csv --method M --out XYZ.csv``: pixels -> 3D with sigma."""
    parser = argparse.ArgumentParser(prog='dempath reconstruct',
                                     description=reconstruct_main.__doc__)
    parser.add_argument('pixels', help='CSV with columns xs,ys,xf,yf (other columns are kept)')
    parser.add_argument('--method', choices=METHODS, default='dlt')
    parser.add_argument('--model', default='',
                        help='model file for mlp / dlt_residual (mlp without one: the shipped '
                             'network, valid for the twin rig only)')
    parser.add_argument('--out', required=True, help='output CSV: input columns + x,y,z [m]')
    parser.add_argument('--sigma', action='store_true', help='add sigma_x,sigma_y,sigma_z [m]')
    parser.add_argument('--sigma-px', default='2.36,2.75', help='pixel noise x,y [px]')
    _common(parser)
    args = parser.parse_args(argv)
    try:
        rows, pixels = _read_pixels_csv(args.pixels)
        est = load_reconstructor(args.method, args.calibration, args.model, args.device)
        if args.method == 'mlp' and not args.model:
            from dempath_recon.methods.shipped import RIG_NOTE

            print(f'mlp: the shipped network, {RIG_NOTE}', file=sys.stderr)
        xyz = est.predict(pixels)
        sx, sy = (float(v) for v in args.sigma_px.split(',')) if args.sigma_px else CLICK_SIGMA_PX
        sigma = sigma_from_covariance(propagate(est, pixels, (sx, sy))) if args.sigma else None
        _write_xyz(args.out, rows, xyz, sigma)
    except (DempathError, ValueError, OSError) as err:
        return _fail(err)
    print(f'{len(rows)} points ({int(np.isnan(xyz[:, 0]).sum())} NaN) -> {args.out}')
    return 0


def _write_xyz(path: str, rows: list[dict[str, str]], xyz: NDArray[np.float64],
               sigma: NDArray[np.float64] | None) -> None:
    extra = ['x', 'y', 'z'] + (['sigma_x', 'sigma_y', 'sigma_z'] if sigma is not None else [])
    with open(path, 'w', newline='') as fh:
        writer = csv.DictWriter(fh, fieldnames=[*rows[0].keys(), *extra])
        writer.writeheader()
        for k, row in enumerate(rows):
            values = list(xyz[k]) + (list(sigma[k]) if sigma is not None else [])
            writer.writerow({**row, **{c: f'{v:.6f}' for c, v in zip(extra, values, strict=True)}})


def report_main(argv: list[str]) -> int:
    """``dempath recon-report POINTS --out DIR``: every method on the paper's held-out split."""
    parser = argparse.ArgumentParser(prog='dempath recon-report', description=report_main.__doc__)
    parser.add_argument('points', help='calibration point set (.npz or .csv)')
    parser.add_argument('--methods', default='dlt,dlt_refined,dlt_residual,mlp')
    parser.add_argument('--out', required=True, help='output folder')
    _common(parser)
    args = parser.parse_args(argv)
    try:
        ps = _load_points(args.points)
        calib = load_calibration(args.calibration) if args.calibration else None
        train, test = holdout_split(len(ps), args.seed)
        rows, errors = [], {}
        for method in args.methods.split(','):
            est = make_reconstructor(method, **_learned_params(args, method))
            row, err = evaluate(method, est, (ps.pixels[train], ps.xyz[train]),
                                (ps.pixels[test], ps.xyz[test]), calib)
            rows.append(row)
            errors[method] = err
        source = 'given calibration' if calib else 'cameras resected from the training rows'
        paths = write_report(args.out, rows, errors,
                             f'{len(ps):,} samples from {args.points}; {len(test):,} held out; '
                             f'triangulation uses {source}.')
    except (DempathError, ValueError, OSError) as err:
        return _fail(err)
    print(paths['markdown'].read_text())
    return 0
