"""The paper's metrics and the before/after trajectories of a finished recalibration.

'Before' is the library's baseline on the seeds the evaluations used, 'after' the
recalibration's own runs at the fitted strengths on the same seeds (paired: the same beds), and
the floor uses every baseline seed of the library
(:mod:`dempath_diagnose.recalibration.paper_metrics`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dempath_diagnose.recalibration.loop import Recalibration
from dempath_diagnose.recalibration.paper_metrics import before_after
from dempath_diagnose.records import Measurement, PassRecord
from dempath_diagnose.report.recalibration_figures import plot_trajectories


def paper_and_trajectories(best: Recalibration, evaluate: Any, library: Any, d: Any,
                           cube: tuple[float, float, float], meas: Measurement, noise_m: float,
                           out: Path) -> tuple[dict[str, Any], tuple[str, ...]]:
    """(the ``paper`` entry of recalibration.json, figure file names written into ``out``).

    ``meas`` is the measured pass as read (markers only), ``noise_m`` the measurement noise per
    axis [m] of the floor's stand-in measurements.
    """
    before = evaluate.baseline_records()
    after_files = evaluate.runs.get(best.strengths, []) if best.changed else []
    after = [(p.stem, PassRecord.load(p)) for p in after_files]
    ((_, files),) = library.model_runs('').items()
    floor = [(f, library.records[f]) for f in files]
    paper = before_after(meas, d.layout, cube, before, after, floor, noise_m)
    paper['after_is_before'] = not after
    fig = plot_trajectories(meas, d.layout, cube, [r for _, r in before],
                            [r for _, r in after], out / 'trajectories.png')
    return paper, (fig,)
