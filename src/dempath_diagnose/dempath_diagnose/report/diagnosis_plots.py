"""Plots of a diagnosis: statistics vs the model band, the error map, the force with its band."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dempath_diagnose.decision.diagnosis import Diagnosis
from dempath_diagnose.decision.statistics import AXES
from dempath_diagnose.records import F64

BAND_SD = 2.0  # the model band is the baseline mean +- this many seed spreads


def plot_all(d: Diagnosis, out: Path) -> list[str]:
    """Write every plot into ``out``; their file names."""
    import matplotlib

    matplotlib.use('Agg')
    return [plot_statistics(d, out / 'statistics.png'), plot_error_map(d, out / 'error_map.png'),
            plot_force(d, out / 'force.png')]


def _series(d: Diagnosis, prefix: str) -> tuple[F64, F64, F64, F64]:
    """Window centres, measured (NaN if unmeasured), model mean and floor for ``group:axis``."""
    names = d.emulator.names
    idx = [i for i, n in enumerate(names) if n.startswith(prefix + ':')]
    centres = d.layout.windows.mean(1)
    if prefix.startswith('force:'):
        centres = centres[list(d.layout.force_windows)]
    measured = np.full(len(idx), np.nan)
    pos = np.cumsum(d.observed) - 1
    for j, i in enumerate(idx):
        if d.observed[i]:
            measured[j] = d.measured[pos[i]]
    return centres, measured, d.emulator.mu0[idx], d.floor[idx]


def plot_statistics(d: Diagnosis, path: Path) -> str:
    """Measured group statistics against the baseline band, one panel per group and axis."""
    import matplotlib.pyplot as plt

    prefixes = list(dict.fromkeys(n.rsplit(':', 1)[0] for n in d.emulator.names
                                  if not n.startswith('force:')))
    cols = 3
    rows = max(1, -(-len(prefixes) // cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3 * rows), squeeze=False)
    for ax, prefix in zip(axes.ravel(), prefixes, strict=False):
        t, y, mu, sd = _series(d, prefix)
        ax.fill_between(t, (mu - BAND_SD * sd) * 1e3, (mu + BAND_SD * sd) * 1e3, alpha=0.3,
                        label=f'model +- {BAND_SD:g} seed sd')
        ax.plot(t, mu * 1e3, 'C0-', label='model mean')
        ax.plot(t, y * 1e3, 'ko', label='measured')
        ax.set_title(prefix)
        ax.set_xlabel('t [s]')
        ax.set_ylabel('[mm]')
    for ax in axes.ravel()[len(prefixes):]:
        ax.axis('off')
    axes.ravel()[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path.name


def plot_error_map(d: Diagnosis, path: Path) -> str:
    """Per-marker discrepancy in seed spreads over the marker layout (X-Z), one panel per axis."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import SymLogNorm

    fig, axes = plt.subplots(1, 3, figsize=(12, 3.8), squeeze=False)
    z = np.nanmean(d.marker_z, axis=1)  # (m, 3) mean over the windows
    starts = d.layout.starts
    top = max(4.0, float(np.nanmax(np.abs(z))) if np.isfinite(z).any() else 4.0)
    # linear within +-2 sd, logarithmic beyond: z = 3 and z = 60 both keep a readable colour
    norm = SymLogNorm(linthresh=2.0, vmin=-top, vmax=top, base=10)
    for k, ax in enumerate(axes.ravel()):
        sc = ax.scatter(starts[:, 2] * 1e3, starts[:, 0] * 1e3, c=z[:, k], cmap='coolwarm',
                        norm=norm, s=420, edgecolors='k')
        for i, m in enumerate(d.layout.markers):
            text = f'{int(m)}\n{z[i, k]:+.1f}' if np.isfinite(z[i, k]) else f'{int(m)}\n-'
            ax.annotate(text, (starts[i, 2] * 1e3, starts[i, 0] * 1e3), fontsize=6,
                        ha='center', va='center')
        ax.set_title(f'{AXES[k]}: measured - model [sd] (marker, z)', fontsize=9)
        ax.set_xlabel('Z start [mm]')
        ax.set_ylabel('X start [mm]')
        fig.colorbar(sc, ax=ax)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path.name


def plot_force(d: Diagnosis, path: Path) -> str:
    """Mean draft per window, measured (if given) against the model band."""
    import matplotlib.pyplot as plt

    t, y, mu, sd = _series(d, 'force:draft')
    fig, ax = plt.subplots(figsize=(5, 3.2))
    ax.fill_between(t, mu - BAND_SD * sd, mu + BAND_SD * sd, alpha=0.3,
                    label=f'model +- {BAND_SD:g} seed sd')
    ax.plot(t, mu, 'C0-', label='model mean')
    if np.any(np.isfinite(y)):
        ax.plot(t, y, 'ko', label='measured')
    ax.set_xlabel('t [s]')
    ax.set_ylabel('draft -Fz [N]')
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path.name
