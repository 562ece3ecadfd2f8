"""Figures of the paper: measured vs N best model trajectories in XZ and YZ (Figures 13-16) and
the 3D view of the tracked trajectories (Figures 11-12). Matplotlib with the Agg backend."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dempath_compare.scoring import CompareResult


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    return plt


def plot_best(result: CompareResult, e: int, path: Path) -> Path:
    """XZ (a) and YZ (b) planes of measured trajectory ``e`` and its N best models (shifted).

    Z (tool travel) on the horizontal axis, in metres, as in the paper's Figures 13-16.
    """
    plt = _pyplot()
    meas, mod = result.measured, result.model
    best = result.best(e)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.12, top=0.86, wspace=0.22)
    exp = meas.positions[e, : meas.lengths[e]]
    for ax, axis, name in ((axes[0], 0, 'X'), (axes[1], 1, 'Y')):
        for j in best:
            p = mod.positions[j, : mod.lengths[j]]
            ax.plot(p[:, 2], p[:, axis], lw=1.0, alpha=0.8,
                    label=f'{mod.idents[j]} (#{result.scores.rank[e, j]})')
        ax.plot(exp[:, 2], exp[:, axis], 'k-o', lw=2.2, ms=3, label=f'experiment {meas.idents[e]}')
        ax.set_xlabel('Z [m] (tool travel)')
        ax.set_ylabel(f'{name} [m]')
        ax.set_title(f'({"ab"[axis]}) {name}Z plane')
        ax.grid(True, alpha=0.3)
    axes[1].legend(fontsize=7, ncol=2, loc='best')
    fig.suptitle(f'{meas.labels[e]}: {len(best)} best model trajectories '
                 f'(ranked by S_{result.config.rank_by.value})')
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def plot_tracked_3d(result: CompareResult, group: str, path: Path) -> Path:
    """3D plot of the measured trajectories of one experiment group at their true positions."""
    plt = _pyplot()
    meas = result.measured
    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection='3d')
    for e in [i for i, g in enumerate(meas.groups) if g == group and meas.lengths[i] > 0]:
        p = meas.positions[e, : meas.lengths[e]] + np.nan_to_num(meas.origins[e])
        duration = meas.times[e, meas.lengths[e] - 1] - meas.times[e, 0]
        ax.plot(p[:, 2], p[:, 0], p[:, 1], '-o', ms=2,
                label=f'marker {meas.idents[e]} ({duration:.2f} s)')
    ax.set_xlabel('Z [m] (travel)')
    ax.set_ylabel('X [m] (lateral)')
    ax.set_zlabel('Y [m] (up)')
    ax.set_title(f'tracked trajectories: {group}')
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
