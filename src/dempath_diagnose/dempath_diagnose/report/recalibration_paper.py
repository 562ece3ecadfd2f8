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
    paper['headline'] = headlines(meas, [r for _, r in before], [r for _, r in after], cube,
                                  noise_m)
    fig = plot_trajectories(meas, d.layout, cube, [r for _, r in before],
                            [r for _, r in after], out / 'trajectories.png')
    from dempath_diagnose.headline.plots import plot_headline

    head = plot_headline([(k, paper['headline'][k]) for k in ('before', 'after')],
                         out / 'headline.png')
    return paper, (fig, head)


def headlines(meas: Any, before: list[PassRecord], after: list[PassRecord],
              cube: tuple[float, float, float], noise_m: float) -> dict[str, Any]:
    """The headline error before and after on the evaluations' seeds, each beside the floor of
    its own model with the same markers, samples and pool size (:mod:`.headline.stage`)."""
    from dempath_diagnose.headline.stage import headline_entry

    out: dict[str, Any] = {}
    for key, model in (('before', before), ('after', after or before)):
        try:
            out[key] = headline_entry(meas, model, cube, noise_m)
        except ValueError as err:
            out[key] = {'error': str(err)}
    return out
