"""Watch the error fall, on the library's own runs: one hidden-effect case, before and after.

A case is a library run (a candidate at one of its strengths, or the baseline: a control) on one
packing seed L that plays the measurement (per marker the particle nearest the marker start,
the cameras' noise, every sample of the pass: :func:`~.samples.played_measurement`). The rest
is what a user's pass goes through, with the library of the other seeds only:

1. the diagnosis on the group statistics of the *fit markers* (the held-out markers are left
   out), markers only (no force), every candidate fitted on the emulator's 121-point strength
   grid (the same budget for every candidate);
2. the headline error (:mod:`.score`) of the measurement against the model *before* (the
   baseline on the other seeds), *after* the true candidate's fit and after the best wrong
   candidate's fit (the one with the lowest d^2 at its best strength), each model on the
   other seeds at its fitted strength (:mod:`.ensemble`), each beside its own floor band
   (:mod:`.floor`: that model on every seed playing the measurement with the same samples,
   pools of as many seeds); a fit is *at its floor* when it lies at or below its band, scores
   significantly lower than the model before the fit and the other fit does not score
   significantly lower, marker by marker (:mod:`.compare`); when both fits are at their floors
   the case says the measurement *cannot separate* them (:func:`separation`);
3. the same on the held-out markers alone;
4. the paper's Table 7 (mean nRMSE over the N best cube candidates, N = 10) before and after
   the true fit, with the same markers, samples, pools and N, and its floor band likewise.

No simulation runs; the models at fitted strengths are the library's paired runs interpolated.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.decision.bandtracks import band_table7
from dempath_diagnose.decision.emulator import Allowance, build_emulator
from dempath_diagnose.decision.statistics import Layout, build_layout
from dempath_diagnose.decision.verdict import decide, fit_candidate
from dempath_diagnose.headline.compare import rival_lower
from dempath_diagnose.headline.d2floor import D2Setup, d2_floor, fold, observed_statistics
from dempath_diagnose.headline.ensemble import emulated_run
from dempath_diagnose.headline.floor import FloorBand, below_reason, floor_band, headline_figure
from dempath_diagnose.headline.samples import MarkerSamples, played_measurement
from dempath_diagnose.headline.score import headline_error
from dempath_diagnose.library.store import Library
from dempath_diagnose.records import F64, Measurement, PassRecord

NAMED = ('effect_missing', 'parameter_off')
D2_VERSION = 2  # d^2 floor: displacements from each played marker's own start
TABLE7_RANKS = 2  # particles per marker start taking turns in Table 7's floor (it is dearer)


@dataclass(frozen=True)
class FallCase:
    """One hidden-effect case.

    Attributes:
        name: Label of the case.
        candidate: The hidden candidate ('' for a control).
        strength: Its strength (the library's).
        seed: The packing seed that plays the measurement.
    """

    name: str
    candidate: str
    strength: float
    seed: int


@dataclass(frozen=True)
class FallSetup:
    """What every case shares.

    Attributes:
        markers: (m,) marker numbers; starts: (m, 3) their starts [m].
        held_out: Marker numbers left out of the fit and scored apart.
        tool_x_m, axis_half_width_m, cube_m: The scene's geometry (diagnosis' CaseGeometry).
        allowance: Noise and discrepancy allowance of the diagnosis.
        n_windows: Time windows of the group statistics.
    """

    markers: F64
    starts: F64
    held_out: tuple[int, ...]
    tool_x_m: float
    axis_half_width_m: float
    cube_m: tuple[float, float, float]
    allowance: Allowance = field(default_factory=Allowance)
    n_windows: int = 4


def model_runs(library: Library, candidate: str, strength: float,
               seeds: Sequence[int]) -> list[PassRecord]:
    """The model (candidate at strength) on ``seeds``."""
    return [emulated_run(library, candidate, strength, s) for s in seeds]


FloorCache = dict[tuple[Any, ...], FloorBand]


def scored(meas: Measurement, samples: MarkerSamples, library: Library, candidate: str,
           strength: float, seed: int, setup: FallSetup,
           cache: FloorCache | None = None) -> dict[str, Any]:
    """The headline error of one model against ``meas`` beside its like-for-like floor band
    (``cache``: floor bands already computed, by model and samples)."""
    seeds = library.seeds()
    pool = model_runs(library, candidate, strength, [s for s in seeds if s != seed])
    error = headline_error(meas, [pool], setup.cube_m)
    key = ('headline', candidate, strength, _samples_key(samples))
    band = (cache or {}).get(key) or floor_band(
        samples, model_runs(library, candidate, strength, seeds),
        headline_figure(setup.cube_m), setup.allowance.noise_m, len(pool))
    if cache is not None:
        cache[key] = band
    out = _placed(error.value, band, 'the headline error', 1e3)
    out['per_marker_mm'] = [None if not np.isfinite(v) else float(v) * 1e3
                            for v in error.per_marker]
    return out


def state(entry: dict[str, Any]) -> str:
    """Where a fitted model's headline ends: 'above' its floor band; 'beaten' (inside, but a
    rival fitted with the same budget scores significantly lower, :mod:`.compare`); 'no_fall'
    (inside, but not significantly lower than the model before the fit, marker by marker: the
    error did not fall, the fitted model's wider band holds it); else 'at_floor'."""
    if entry['place'] == 'above':
        return 'above'
    if entry.get('rival', {}).get('lower', False):
        return 'beaten'
    if not entry['fall']['lower']:
        return 'no_fall'
    return 'at_floor'


def at_floor(entry: dict[str, Any]) -> bool:
    """A fitted model's headline at or below its floor band, significantly lower than before
    the fit, and no rival fitted with the same budget scoring significantly lower."""
    return state(entry) == 'at_floor'


def with_falls(part: dict[str, Any]) -> dict[str, Any]:
    """``part`` ('all' or 'held_out' of a case) with each fit's ``fall``: does the fitted model
    score significantly lower than the model before, marker by marker (:mod:`.compare`)?"""
    for key in ('after_true', 'after_wrong'):
        if key in part:
            part[key]['fall'] = rival_lower(_per_marker(part['before']), _per_marker(part[key]))
    return part


def separation(result: dict[str, Any]) -> str:
    """What a case's two fits show: 'true_at_floor', 'wrong_at_floor', 'cannot_separate' (both
    fits at their floors and neither scores significantly lower: the measurement cannot tell
    the true effect from its rival) or 'neither'."""
    a = result['all']
    true = 'after_true' in a and at_floor(a['after_true'])
    wrong = at_floor(a['after_wrong'])
    if true and wrong:
        return 'cannot_separate'
    return 'true_at_floor' if true else 'wrong_at_floor' if wrong else 'neither'


def _per_marker(entry: dict[str, Any]) -> F64:
    return np.array([np.nan if v is None else v for v in entry['per_marker_mm']]) * 1e-3


def _samples_key(samples: MarkerSamples) -> tuple[Any, ...]:
    return (tuple(samples.markers.tolist()), samples.starts.tobytes(), samples.times.tobytes(),
            samples.present.tobytes())


def table7(meas: Measurement, samples: MarkerSamples, library: Library, candidate: str,
           strength: float, seed: int, setup: FallSetup,
           cache: FloorCache | None = None) -> dict[str, Any]:
    """The paper's mean nRMSE [%] of one model, like for like with its floor band."""
    seeds = library.seeds()
    pool = model_runs(library, candidate, strength, [s for s in seeds if s != seed])
    table = band_table7(meas, pool, setup.cube_m)

    def figure(m: Measurement, p: Sequence[PassRecord]) -> float:
        return float(band_table7(m, p, setup.cube_m)['mean_nrmse_pct'])

    key = ('table7', candidate, strength, _samples_key(samples))
    band = (cache or {}).get(key) or floor_band(
        samples, model_runs(library, candidate, strength, seeds), figure,
        setup.allowance.noise_m, len(pool), ranks=TABLE7_RANKS)
    if cache is not None:
        cache[key] = band
    out = _placed(float(table['mean_nrmse_pct']), band, 'the mean nRMSE', 1.0)
    out['n_best'] = {str(r['marker']): r['n_best'] for r in table['rows']}
    out['markers'] = len(table['rows'])
    return out


def _placed(value: float, band: FloorBand, name: str, scale: float) -> dict[str, Any]:
    place = band.place(value)
    return {'value': value * scale, 'floor': band.to_json(scale), 'place': place,
            'why_below': below_reason(place, name)}


def _measured(library: Library, case: FallCase,
              setup: FallSetup) -> tuple[Measurement, MarkerSamples, NDArray[np.bool_]]:
    """The case's measurement (its seed's run, every marker, 1.5 mm noise), its samples and
    the held-out mask (deterministic: the same on every call)."""
    rng = np.random.default_rng(case.seed)
    truth = emulated_run(library, case.candidate, case.strength, case.seed)
    times = np.round(np.arange(0.0, float(truth.times[-1]) + 1e-9, 0.005), 6)
    times = times[times <= float(library.records[library.runs[0].filename].times[-1])]
    samples = MarkerSamples(setup.markers.astype(np.int64), setup.starts, times,
                            np.ones((len(times), len(setup.markers)), bool))
    meas = played_measurement(truth, samples, 0, setup.allowance.noise_m, rng)
    return meas, samples, np.isin(samples.markers, setup.held_out)


def redo_d2(library: Library, case: FallCase, setup: FallSetup,
            cache: FloorCache | None = None) -> dict[str, Any]:
    """Only the d^2 entries of a case (for results stored before d^2's floor changed)."""
    meas, samples, held = _measured(library, case, setup)
    decision, fits, layout = _diagnose(library, _only(meas, ~held), case.seed, setup)
    true_fit = next((f for f in fits if f.name == case.candidate), None)
    return _d2_entries(library, case, samples.subset(~held), layout, setup, decision, true_fit,
                       cache)


def run_case(library: Library, case: FallCase, setup: FallSetup, with_table7: bool = True,
             cache: FloorCache | None = None) -> dict[str, Any]:
    """Everything of one case (see the module docstring), JSON-ready (mm, %)."""
    meas, samples, held = _measured(library, case, setup)
    times = samples.times
    fit_meas = _only(meas, ~held)
    decision, fits, layout = _diagnose(library, fit_meas, case.seed, setup)
    true_fit = next((f for f in fits if f.name == case.candidate), None)
    wrong, skipped = None, []
    for f in sorted((f for f in fits if f.name != case.candidate), key=lambda f: f.chi2):
        try:  # the best wrong fit whose model can be scored on these markers
            scored(meas, samples, library, f.name, f.strength, case.seed, setup, cache)
        except ValueError as err:
            skipped.append({'candidate': f.name, 'strength': f.strength, 'why': str(err)})
            continue
        wrong = f
        break
    if wrong is None:
        raise ValueError(f'{case.name}: no wrong candidate could be scored ({skipped})')
    out: dict[str, Any] = {
        'case': case.name, 'candidate': case.candidate, 'strength': case.strength,
        'seed': case.seed, 'verdict': decision.verdict,
        'top': decision.ranking[0].name, 'top_probability': decision.ranking[0].probability,
        'd2_before': decision.baseline.chi2, 'fit_markers': len(fit_meas.markers),
        'window_s': [float(times[0]), float(times[-1])],
        'markers': [int(m) for m in samples.markers], 'held_out': list(setup.held_out)}
    parts = {'all': (meas, samples), 'held_out': (_only(meas, held), samples.subset(held))}
    models = {'before': ('', 0.0)}
    if true_fit is not None:
        models['after_true'] = (case.candidate, true_fit.strength)
        out['true_fit'] = {'strength': true_fit.strength, 'sd': true_fit.strength_sd,
                           'd2': true_fit.chi2}
    models['after_wrong'] = (wrong.name, wrong.strength)
    out['wrong_fit'] = {'candidate': wrong.name, 'strength': wrong.strength, 'd2': wrong.chi2,
                        'skipped': skipped}
    for part, (m, s) in parts.items():
        out[part] = {key: scored(m, s, library, c, x, case.seed, setup, cache)
                     for key, (c, x) in models.items()}
        if 'after_true' in out[part]:
            true_e, wrong_e = out[part]['after_true'], out[part]['after_wrong']
            true_e['rival'] = rival_lower(_per_marker(true_e), _per_marker(wrong_e))
            wrong_e['rival'] = rival_lower(_per_marker(wrong_e), _per_marker(true_e))
        with_falls(out[part])
    out['d2'] = _d2_entries(library, case, samples.subset(~held), layout, setup, decision,
                            true_fit, cache)
    if with_table7:
        out['table7'] = {key: table7(meas, samples, library, c, x, case.seed, setup, cache)
                         for key, (c, x) in models.items() if key != 'after_wrong'}
    return out


def _d2_entries(library: Library, case: FallCase, samples: MarkerSamples, layout: Layout,
               setup: FallSetup, decision: Any, true_fit: Any,
               cache: FloorCache | None) -> dict[str, Any]:
    """d^2 before and after the true fit (fit markers), each beside its like-for-like floor
    (:mod:`.d2floor`: each seed plays the measurement against the emulator of the other two,
    as the case's seed does in the figure)."""
    d2setup = D2Setup(layout, setup.cube_m, setup.allowance)
    out: dict[str, Any] = {}
    models = [('before', '', 0.0, float(decision.baseline.chi2), False)]
    if true_fit is not None:
        models.append(('after_true', case.candidate, float(true_fit.strength),
                       float(true_fit.chi2), True))
    for key, cand, x, value, fitted in models:
        ck = ('d2', D2_VERSION, cand, x, fitted, _samples_key(samples),
              tuple(tuple(g.members.tolist()) for g in layout.groups),
              layout.windows.tobytes())
        band = (cache or {}).get(ck) or d2_floor(library, cand, x, samples, d2setup, fitted)
        if cache is not None:
            cache[ck] = band
        out[key] = _placed(value, band, 'd^2', 1.0)
    out['version'] = D2_VERSION
    return out


def _only(meas: Measurement, keep: NDArray[np.bool_]) -> Measurement:
    return Measurement(meas.markers[keep], meas.times, meas.positions[:, keep])


def _diagnose(library: Library, meas: Measurement, seed: int,
              setup: FallSetup) -> tuple[Any, list[Any], Layout]:
    """The decision, every candidate's fit and the layout, on the library without ``seed``
    (no force)."""
    lib = fold(library, seed)
    first = lib.records[lib.runs[0].filename]
    end = float(meas.times[-1])
    layout = build_layout(meas.markers, meas.start, setup.tool_x_m, setup.axis_half_width_m,
                          end, float(first.meta.get('tool_stop_s', end)), setup.n_windows)
    emu = build_emulator(lib, layout, setup.cube_m)
    y, observed = observed_statistics(emu, meas, layout)
    cov = emu.fixed_cov(setup.allowance, layout)
    fits = [fit_candidate(emu, c, y, observed, cov) for c in emu.candidates]
    return decide(emu, y, observed, cov), fits, layout


def summary(results: Sequence[dict[str, Any]], table7_like_for_like: bool) -> dict[str, Any]:
    """The bench's figures over every case (see bench/error_fall.py)."""
    effects = [r for r in results if r['candidate']]
    controls = [r for r in results if not r['candidate']]
    seen = [r for r in effects if r['all']['before']['place'] == 'above']
    true_in = [r for r in seen if separation(r) == 'true_at_floor']
    wrong_in = [r for r in seen if separation(r) == 'wrong_at_floor']
    mixed = [r for r in seen if separation(r) == 'cannot_separate']
    no_fall = [r for r in seen if state(r['all']['after_wrong']) == 'no_fall']
    wrong_band = [r for r in seen if r['all']['after_wrong']['place'] != 'above']
    held_fell = [r for r in seen if r['held_out']['after_true']['value']
                 < r['held_out']['before']['value']]
    t7 = [r for r in effects if 'table7' in r]
    t7_fell = [r for r in t7 if r['table7']['after_true']['value']
               < r['table7']['before']['value'] - 1e-9]
    return {'cases': len(results), 'effect_cases': len(effects),
            'effect_seen': len(seen), 'true_fit_in_floor': len(true_in),
            'wrong_fit_in_floor': len(wrong_in), 'cannot_separate': len(mixed),
            'wrong_fit_in_own_band': len(wrong_band), 'wrong_fit_no_fall': len(no_fall),
            'control_moved': sum(r['verdict'] in NAMED for r in controls),
            'controls': len(controls), 'held_out_fell': len(held_fell),
            'table7_like_for_like': table7_like_for_like,
            'table7_fell': len(t7_fell), 'table7_cases': len(t7),
            'd2_floor_like_for_like': all('d2' in r for r in results),
            'd2_before_above': sum(r['d2']['before']['place'] == 'above'
                                   for r in effects if 'd2' in r),
            'd2_true_fit_in_floor': sum(r['d2']['after_true']['place'] != 'above'
                                        for r in effects if 'after_true' in r.get('d2', {})),
            'd2_true_fit_below_floor': sum(r['d2']['after_true']['place'] == 'below'
                                           for r in effects if 'after_true' in r.get('d2', {})),
            'not_seen': sorted({r['case'] for r in effects if r not in seen}),
            'true_fit_not_at_floor': sorted(f"{r['case']}@{r['seed']}" for r in seen
                                           if r not in true_in),
            'wrong_fit_in_floor_cases': sorted(f"{r['case']}@{r['seed']}" for r in wrong_in),
            'cannot_separate_cases': sorted(f"{r['case']}@{r['seed']}" for r in mixed)}


def finite(value: float) -> float | None:
    """JSON-safe number."""
    return value if math.isfinite(value) else None
