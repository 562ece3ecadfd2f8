"""The paper's metrics and the before/after trajectories of a finished recalibration.

'Before' is the library's baseline on the seeds the evaluations used, 'after' the
recalibration's own runs at the fitted strengths on the same seeds (paired: the same beds). Each
has its own Table 7 floor, like for like (the same markers, samples, noise and pool size): the
baseline on every library seed before, the fitted model on every library seed after (the
library's paired runs interpolated at the fitted strength)
(:mod:`dempath_diagnose.recalibration.paper_metrics`). The headline error is given for the model
before and for every evaluated iteration, each beside its own floor band.
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
                           out: Path, held: Measurement | None = None,
                           ) -> tuple[dict[str, Any], tuple[str, ...]]:
    """(the ``paper`` entry of recalibration.json, figure file names written into ``out``).

    ``meas`` is the measured pass as read (markers only) without the held-out markers,
    ``held`` those markers (left out of the diagnosis and the fit; their headline error before
    and after is the held-out check), ``noise_m`` the measurement noise per axis [m] of the
    floor's stand-in measurements.
    """
    before = evaluate.baseline_records()
    after_files = evaluate.runs.get(best.strengths, []) if best.changed else []
    after = [(p.stem, PassRecord.load(p)) for p in after_files]
    ((_, files),) = library.model_runs('').items()
    floor = [(f, library.records[f]) for f in files]
    paper = before_after(meas, d.layout, cube, before, after, floor, noise_m,
                         fitted_model(best, library) if after else ())
    paper['after_is_before'] = not after
    paper['headline'] = headlines(meas, [r for _, r in before], [r for _, r in after], cube,
                                  noise_m)
    if held is not None and len(held.markers):
        paper['headline_held_out'] = {
            'markers': [int(m) for m in held.markers],
            **headlines(held, [r for _, r in before], [r for _, r in after], cube, noise_m)}
    paper['headline_iterations'] = iteration_headlines(meas, evaluate, before, cube, noise_m)
    fig = plot_trajectories(meas, d.layout, cube, [r for _, r in before],
                            [r for _, r in after], out / 'trajectories.png')
    from dempath_diagnose.headline.plots import plot_headline

    head = plot_headline([(k, paper['headline'][k]) for k in ('before', 'after')],
                         out / 'headline.png')
    rows = [(it['label'], it) for it in paper['headline_iterations']]
    per_iteration = plot_headline(rows, out / 'headline_iterations.png',
                                  'the headline error per iteration') if rows else None
    return paper, tuple(f for f in (fig, head, per_iteration) if f)


def fitted_model(best: Recalibration, library: Any) -> list[tuple[str, PassRecord]]:
    """The recalibrated model on every library seed, for its own Table 7 floor: the library's
    paired runs interpolated at the fitted strength (:mod:`.headline.ensemble`); empty when
    more than one parameter was fitted (no paired runs span them together)."""
    from dempath_diagnose.headline.ensemble import emulated_run

    if len(best.params) != 1:
        return []
    return [(f'{best.effect}-s{s}', emulated_run(library, best.effect, best.strengths[0], s))
            for s in library.seeds()]


def iteration_headlines(meas: Any, evaluate: Any, before: list[tuple[str, PassRecord]],
                        cube: tuple[float, float, float], noise_m: float) -> list[dict[str, Any]]:
    """The headline error of the model as it is and of every evaluated iteration (the real
    runs at that iteration's strengths), each beside its own floor band."""
    from dempath_diagnose.headline.stage import headline_entry

    models = [('before', [r for _, r in before])]
    for i, (x, paths) in enumerate(evaluate.runs.items(), start=1):
        label = f"iteration {i}: {', '.join(f'{v:.4g}' for v in x)}"
        models.append((label, [PassRecord.load(p) for p in paths]))
    out = []
    for label, model in models:
        try:
            entry = headline_entry(meas, model, cube, noise_m)
        except ValueError as err:
            entry = {'error': str(err)}
        out.append({'label': label, **entry})
    return out


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
