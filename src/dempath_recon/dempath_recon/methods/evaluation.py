"""Side-by-side evaluation of the reconstruction methods against the paper's Table 5.

The paper (Technologies 2025, 13, 570, sec. 3, Table 5 and Figure 8) held out 4,149 of its
94,939 calibration samples and reported, for its network on them: mean 3D error 2.9 mm, standard
deviation 2.7 mm, maximum 23.9 mm, R2 0.9994 (X), 0.9993 (Y), 0.9988 (Z). This module computes
the same figures for every method on the same held-out rows, with training time and throughput,
and writes a Markdown table, a JSON file and the histogram of the 3D error (the paper's Fig. 8).
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
logger = logging.getLogger(__name__)

PAPER_TABLE5: dict[str, Any] = {'mean_mm': 2.9, 'sd_mm': 2.7, 'max_mm': 23.9,
                                'r2': [0.9994, 0.9993, 0.9988]}
PAPER_N_TOTAL, PAPER_N_TEST = 94_939, 4_149  # samples in the paper's point set / its test set


def holdout_split(n: int, seed: int = 0,
                  test_fraction: float = PAPER_N_TEST / PAPER_N_TOTAL) -> tuple[NDArray[Any], ...]:
    """Random train / test row indices with the paper's test share (4,149 of 94,939).

    Returns:
        (train_idx, test_idx), int arrays; for n = 94,939 the test part has exactly 4,149 rows.
    """
    perm = np.random.default_rng(seed).permutation(n)
    n_test = max(1, round(test_fraction * n))
    return np.sort(perm[n_test:]), np.sort(perm[:n_test])


def r2_scores(pred: FloatArray, truth: FloatArray) -> list[float]:
    """Coefficient of determination per axis, ``1 - SS_res / SS_tot`` (scikit-learn's r2_score)."""
    ss_res = ((truth - pred) ** 2).sum(axis=0)
    ss_tot = ((truth - truth.mean(axis=0)) ** 2).sum(axis=0)
    return [float(v) for v in 1.0 - ss_res / ss_tot]


def error_metrics(pred: FloatArray, truth: FloatArray) -> dict[str, Any]:
    """Mean, SD (ddof 1) and max of the 3D error in mm, R2 per axis, and the rows that failed.

    Args:
        pred: (n, 3) predicted points [m]; NaN rows count as failed and are left out.
        truth: (n, 3) reference points [m].
    """
    ok = np.isfinite(pred).all(axis=1)
    err = np.linalg.norm(pred[ok] - truth[ok], axis=1) * 1e3
    return {'n': int(ok.sum()), 'n_failed': int((~ok).sum()), 'mean_mm': float(err.mean()),
            'sd_mm': float(err.std(ddof=1)), 'max_mm': float(err.max()),
            'median_mm': float(np.median(err)), 'p95_mm': float(np.percentile(err, 95)),
            'r2': r2_scores(pred[ok], truth[ok])}


@dataclass
class MethodResult:
    """One row of the comparison (errors on the held-out rows, times on this machine)."""

    name: str
    mean_mm: float
    sd_mm: float
    max_mm: float
    r2: list[float]
    train_s: float
    points_per_s: float
    n_test: int
    notes: str = ''
    extra: dict[str, Any] = field(default_factory=dict)


def measure_throughput(estimator: Any, pixels: FloatArray, min_points: int = 100_000) -> float:
    """Point pairs per second of ``predict`` on at least ``min_points`` rows (tiled)."""
    reps = max(1, int(np.ceil(min_points / len(pixels))))
    batch = np.tile(pixels, (reps, 1))
    estimator.predict(batch[:1000])  # warm-up (imports, allocations)
    start = time.perf_counter()
    estimator.predict(batch)
    return len(batch) / (time.perf_counter() - start)


def evaluate(name: str, estimator: Any, train: tuple[FloatArray, FloatArray],
             test: tuple[FloatArray, FloatArray], calibration: Any = None,
             notes: str = '') -> tuple[MethodResult, FloatArray]:
    """Fit on ``train``, score on ``test``; returns the row and the (n_test,) errors [mm]."""
    start = time.perf_counter()
    estimator.fit(train[0], train[1], calibration=calibration)
    train_s = time.perf_counter() - start
    pred = estimator.predict(test[0])
    m = error_metrics(pred, test[1])
    errors = np.linalg.norm(pred - test[1], axis=1) * 1e3
    extra = {k: m[k] for k in ('median_mm', 'p95_mm', 'n_failed')}
    if hasattr(estimator, 'n_iter_'):
        extra['epochs_run'] = estimator.n_iter_
    logger.info('%s: mean %.3f mm, max %.3f mm, trained in %.1f s', name, m['mean_mm'],
                m['max_mm'], train_s)
    row = MethodResult(name, m['mean_mm'], m['sd_mm'], m['max_mm'], m['r2'], train_s,
                       measure_throughput(estimator, test[0]), m['n'], notes, extra)
    return row, errors


def best_method(rows: list[MethodResult]) -> str:
    """Name of the row with the lowest mean 3D error ('' for no rows)."""
    return min(rows, key=lambda r: r.mean_mm).name if rows else ''


def fastest_meeting(rows: list[MethodResult], mean_mm: float = 0.5,
                    max_mm: float = 3.0) -> str:
    """Name of the fastest-training row with mean <= ``mean_mm`` and max <= ``max_mm`` ('')."""
    ok = [r for r in rows if r.mean_mm <= mean_mm and r.max_mm <= max_mm]
    return min(ok, key=lambda r: r.train_s).name if ok else ''


def markdown_table(rows: list[MethodResult]) -> str:
    """The comparison as Markdown, the paper's Table 5 figures in the first data column."""
    head = '| figure | paper MLP (Table 5) | ' + ' | '.join(r.name for r in rows) + ' |'
    lines = [head, '|' + ' --- |' * (len(rows) + 2)]
    p = PAPER_TABLE5

    def line(label: str, paper: str, values: list[str]) -> str:
        return f'| {label} | {paper} | ' + ' | '.join(values) + ' |'

    lines.append(line('mean 3D error [mm]', f'{p["mean_mm"]}', [f'{r.mean_mm:.3f}' for r in rows]))
    lines.append(line('SD of 3D error [mm]', f'{p["sd_mm"]}', [f'{r.sd_mm:.3f}' for r in rows]))
    lines.append(line('max 3D error [mm]', f'{p["max_mm"]}', [f'{r.max_mm:.3f}' for r in rows]))
    for k, axis in enumerate('XYZ'):
        lines.append(line(f'R2 {axis}', f'{p["r2"][k]}', [f'{r.r2[k]:.6f}' for r in rows]))
    lines.append(line('training time [s]', 'n/a', [f'{r.train_s:.1f}' for r in rows]))
    lines.append(line('throughput [points/s]', 'n/a', [f'{r.points_per_s:,.0f}' for r in rows]))
    lines.append(line('held-out points', f'{PAPER_N_TEST:,}', [f'{r.n_test:,}' for r in rows]))
    return '\n'.join(lines)


def plot_error_histogram(errors: dict[str, FloatArray], path: str | Path) -> Path:
    """Histogram of the 3D error per method (the paper's Figure 8), log-scaled x; a PNG."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    path = Path(path)
    fig, ax = plt.subplots(figsize=(7, 4), dpi=120)
    finite = np.concatenate([e[np.isfinite(e)] for e in errors.values()])
    bins = np.geomspace(max(finite.min(), 1e-3), finite.max() * 1.01, 60)
    for name, err in errors.items():
        ax.hist(err[np.isfinite(err)], bins=bins.tolist(), histtype='step', linewidth=1.5,
                label=name)
    ax.axvline(PAPER_TABLE5['mean_mm'], color='k', linestyle='--', linewidth=1,
               label='paper MLP mean (2.9 mm)')
    ax.set_xscale('log')
    ax.set_xlabel('3D position error [mm]')
    ax.set_ylabel('held-out samples')
    ax.set_title('3D error on held-out calibration points (cf. paper Fig. 8)')
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def write_report(out_dir: str | Path, rows: list[MethodResult], errors: dict[str, FloatArray],
                 header: str = '') -> dict[str, Path]:
    """Write ``report.md``, ``report.json`` and ``error_histogram.png`` into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    png = plot_error_histogram(errors, out / 'error_histogram.png')
    md = out / 'report.md'
    md.write_text(f'# Reconstruction accuracy\n\n{header}\n\n{markdown_table(rows)}\n\n'
                  f'![3D error histogram]({png.name})\n')
    js = out / 'report.json'
    js.write_text(json.dumps({'paper_table5': PAPER_TABLE5, 'best': best_method(rows),
                              'methods': [asdict(r) for r in rows]}, indent=1))
    return {'markdown': md, 'json': js, 'histogram': png}
