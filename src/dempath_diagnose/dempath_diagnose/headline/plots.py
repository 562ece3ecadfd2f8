"""Pictures of the headline error: each figure as a dot beside its own floor band."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

COLOURS = {'above': 'C3', 'in': 'C2', 'below': 'C0'}


def plot_headline(entries: Sequence[tuple[str, dict[str, Any]]], path: Path,
                  title: str = '') -> str:
    """One row per (label, headline entry): the floor band shaded, the value a dot coloured by
    where it lies (red above the band, green inside, blue below); returns the file name."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    rows = [(label, e) for label, e in entries if e.get('value_mm') is not None]
    fig, ax = plt.subplots(figsize=(6.4, 0.7 * len(rows) + 1.3))
    for i, (_label, e) in enumerate(rows):
        f = e['floor_mm']
        ax.barh(i, f['high'] - f['low'], left=f['low'], height=0.5, color='0.85',
                label='floor band (the model as the measurement)' if i == 0 else None)
        ax.plot(e['value_mm'], i, 'o', ms=9, color=COLOURS[e['place']])
        ax.annotate(f"{e['value_mm']:.1f} mm ({e['place']})", (e['value_mm'], i),
                    xytext=(8, 6), textcoords='offset points', fontsize=8)
    ax.set_yticks(range(len(rows)), [label for label, _ in rows])
    ax.set_xlabel('headline error: energy score per sample [mm]')
    ax.set_xlim(left=0.0)
    ax.set_ylim(-0.7, len(rows) - 0.3)
    ax.legend(loc='lower right', fontsize=7)
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name


def plot_error_fall(results: Sequence[dict[str, Any]], path: Path) -> str:
    """The bench's cases: headline before, after the true fit and after the best wrong fit, each
    beside its floor band (one row per case and seed)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    rows = [r for r in results if r['candidate']] + [r for r in results if not r['candidate']]
    fig, ax = plt.subplots(figsize=(8.0, 0.32 * len(rows) + 1.4))
    styles = (('before', -0.25, 'C3', 'o', 'before (model as it is)'),
              ('after_true', 0.0, 'C2', 'D', 'after the true fit'),
              ('after_wrong', 0.25, '0.35', 'x', 'after the best wrong fit'))
    for i, r in enumerate(rows):
        for key, dy, colour, mark, label in styles:
            f = r['all'].get(key)
            if not f:
                continue
            ax.plot([f['floor']['low'], f['floor']['high']], [i + dy] * 2, '-', color=colour,
                    alpha=0.35, lw=4)
            ax.plot(f['value'], i + dy, mark, color=colour, ms=5,
                    label=label if i == 0 else None)
            if f.get('rival', {}).get('lower'):  # the measurement prefers the other fit
                ax.annotate('rival lower', (f['value'], i + dy), xytext=(5, -3),
                            textcoords='offset points', fontsize=6, color=colour)
    ax.set_yticks(range(len(rows)), [f"{r['case']} s{r['seed']}" for r in rows], fontsize=7)
    ax.set_xscale('log')
    ax.set_xlabel("headline error [mm]; bars: each model's floor band, like for like\n"
                  "'rival lower': the other fit scores significantly lower, marker by marker",
                  fontsize=8)
    ax.invert_yaxis()
    ax.legend(fontsize=7, loc='lower right')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name
