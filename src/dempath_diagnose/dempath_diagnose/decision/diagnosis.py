"""One diagnosis: measured pass + scene + signature library -> decision and where the model fails.

The steps: the layout from the measured start positions (:func:`statistics.build_layout`), the
emulator of the library for that layout, the measured statistics, the decision, and the
per-marker / per-group breakdown of the discrepancy against the baseline's seed spread. No
simulation runs here (the library is built before, :mod:`dempath_diagnose.library.store`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath.errors import DempathError
from dempath_diagnose.decision.bandtracks import band_table7
from dempath_diagnose.decision.emulator import Allowance, Emulator, build_emulator
from dempath_diagnose.decision.measure import check_force_scale
from dempath_diagnose.decision.range_edge import edge_decision
from dempath_diagnose.decision.statistics import AXES, Layout, build_layout, measured_statistics
from dempath_diagnose.decision.thin import thin_decision
from dempath_diagnose.decision.verdict import Decision, decide
from dempath_diagnose.errors import MeasurementError
from dempath_diagnose.library.store import Library
from dempath_diagnose.records import F64, Measurement

COVERAGE_SLACK_S = 0.02  # the measurement may end this much after the library's last frame [s]


@dataclass(frozen=True)
class CaseGeometry:
    """What the statistics need to know of the scene.

    Attributes:
        tool_x_m: X of the tool axis [m].
        axis_half_width_m: Markers within this lateral distance of the axis are on the axis [m].
        cube_m: Candidate cube size (X, Y, Z) [m].
    """

    tool_x_m: float
    axis_half_width_m: float
    cube_m: tuple[float, float, float]


@dataclass
class Diagnosis:
    """The result of :func:`diagnose`.

    Attributes:
        decision: Verdict and ranked fits.
        layout: Groups and windows.
        emulator: The library's emulator for the layout.
        measured: (k_obs,) measured statistics.
        observed: (k,) which statistics were measured.
        cov: (k, k) fixed covariance (seed + sampling + noise + discrepancy).
        marker_z: (m, K, 3) per-marker discrepancy over the baseline spread (error map).
        marker_error: (m, K, 3) per-marker measured minus baseline mean [m].
        problems: Per-marker faults from loading.
        wall_s: Time taken [s].
        simulations: Library runs the diagnosis rests on.
        table7: The paper's Table 7 of the baseline band against the measured markers
            (:func:`~dempath_diagnose.decision.bandtracks.band_table7`).
        headline: The headline error of the baseline beside its like-for-like floor
            (:func:`~dempath_diagnose.headline.stage.with_headline`), added above the
            decision by whoever reports it (the entry point, the node); empty until then.
        adaptive: What simulations beyond the library were run and why (``--budget``;
            :meth:`~dempath_diagnose.adaptive.AdaptiveResult.to_dict`), empty when none were
            allowed.
        measurement: The measured pass as diagnosed (the markers inside a packed library's
            region).
        held_out: The markers left out of the diagnosis and scored apart (``None``: none).
        held_headline: The headline error of the baseline on ``held_out`` beside its floor,
            added with ``headline`` (empty when no marker was held out).
    """

    decision: Decision
    layout: Layout
    emulator: Emulator
    measured: F64
    observed: NDArray[np.bool_]
    cov: F64
    marker_z: F64
    marker_error: F64
    problems: dict[int, str] = field(default_factory=dict)
    wall_s: float = 0.0
    simulations: int = 0
    table7: dict[str, Any] = field(default_factory=dict)
    headline: dict[str, Any] = field(default_factory=dict)
    adaptive: dict[str, Any] = field(default_factory=dict)
    measurement: Measurement | None = None
    held_out: Measurement | None = None
    held_headline: dict[str, Any] = field(default_factory=dict)

    @property
    def floor(self) -> F64:
        """(k,) what chaos alone gives: the baseline's seed + sampling sd per statistic."""
        return np.sqrt(np.diag(self.emulator.seed_cov + self.emulator.sampling_cov))


def diagnose(meas: Measurement, library: Library, geometry: CaseGeometry,
             allowance: Allowance | None = None, n_windows: int = 4,
             force_source: str | Path = 'force') -> Diagnosis:
    """Diagnose one measured pass against a built library.

    Raises:
        MeasurementError: The measurement lasts longer than the library covers, or its force
            looks like another unit.
    """
    t0 = time.monotonic()
    allowance = allowance or Allowance()
    first = next(iter(library.records.values()))
    cover = float(first.times[-1])
    end = float(meas.times[-1])
    if end > cover + COVERAGE_SLACK_S:
        msg = (f'measured window: ends at t = {end:.3f} s, the model library covers '
               f'{cover:.3f} s; give no --library, and dempath diagnose builds one that covers '
               'the window')
        raise MeasurementError(msg)
    if library.region is not None:
        meas = _inside_region(meas, library)
    stop = float(first.meta.get('tool_stop_s', cover))
    layout = build_layout(meas.markers, meas.start, geometry.tool_x_m,
                          geometry.axis_half_width_m, end, stop, n_windows, measured=meas)
    emu = build_emulator(library, layout, geometry.cube_m)
    y, features = measured_statistics(meas, layout)
    force = emu.is_force()
    observed = np.ones(len(emu.names), bool) if meas.has_force else ~force
    if meas.has_force:
        check_force_scale(Path(force_source), float(np.mean(y[force])),
                          float(np.mean(emu.mu0[force])))
    finite = np.isfinite(y)
    observed_idx = np.flatnonzero(observed)
    observed[observed_idx[~finite]] = False
    y = y[finite]
    cov = emu.fixed_cov(allowance, layout)
    decision = edge_decision(thin_decision(decide(emu, y, observed, cov), layout), emu)
    err, z = _marker_map(emu, features, allowance)
    table7 = baseline_table7(meas, library, geometry.cube_m)
    return Diagnosis(decision, layout, emu, y, observed, cov, z, err, dict(meas.problems),
                     time.monotonic() - t0, len(library.runs), table7, measurement=meas)


def _inside_region(meas: Measurement, library: Library) -> Measurement:
    """``meas`` without the markers that start outside a packed library's region (reported
    as per-marker faults: their model counterparts are not in the file)."""
    from dataclasses import replace

    from dempath_diagnose.library.packed import outside_region

    assert library.region is not None
    out = outside_region(library.region, meas.start, meas.markers.tolist())
    if not out:
        return meas
    bad = {int(text.split()[1]) for text in out}
    if len(bad) == len(meas.markers):
        msg = (f'{library.folder}: every marker starts outside the region the library was '
               f'packed for (e.g. {out[0]}); use the full library or pack it for these markers')
        raise MeasurementError(msg)
    keep = np.array([int(m) not in bad for m in meas.markers])
    problems = {**meas.problems, **{m: "starts outside the packed library's region"
                                    for m in bad}}
    return replace(meas, markers=meas.markers[keep], positions=meas.positions[:, keep],
                   problems=problems)


def baseline_table7(meas: Measurement, library: Library,
                    cube: tuple[float, float, float]) -> dict[str, Any]:
    """The paper's Table 7 of the library's baseline runs against the measured markers.

    A fault of the comparison (no scorable trajectory at all) is reported in the result
    (``error``), not raised: the group statistics do not depend on it.
    """
    files = [f for runs in library.model_runs('').values() for f in runs]
    try:
        return band_table7(meas, [library.records[f] for f in files], cube,
                           [f.removesuffix('.npz') for f in files])
    except (DempathError, ValueError) as err:
        return {'error': str(err), 'rows': [], 'mean_nrmse_pct': float('nan')}


def _marker_map(emu: Emulator, features: F64, allowance: Allowance) -> tuple[F64, F64]:
    """Per-marker (m, K, 3) error against the baseline mean and in units of its spread."""
    mean = emu.features0.mean(0)
    seed_var = emu.features0.var(0, ddof=1) if len(emu.features0) > 1 else 0.0
    spread = np.sqrt(seed_var + emu.feature_var + allowance.noise_m**2)
    err = features - mean
    return err, err / spread


def sentences(d: Diagnosis, limit: int = 3) -> list[str]:
    """A few plain sentences on the largest significant group discrepancies."""
    names = [n for n, o in zip(d.emulator.names, d.observed, strict=True) if o]
    idx = np.flatnonzero(d.observed)
    base = d.emulator.mu0[idx]
    sd = d.floor[idx]
    z = (d.measured - base) / sd
    out = []
    seen: set[tuple[str, str]] = set()
    for k in np.argsort(-np.abs(z)):
        group, axis, _ = names[k].split(':')
        if abs(z[k]) < 2.0 or (group, axis) in seen:
            continue
        seen.add((group, axis))
        window = d.layout.windows[int(names[k].rsplit('w', 1)[1])]
        out.append(_sentence(group, axis, d.measured[k] - base[k], z[k], window[0]))
        if len(out) == limit:
            break
    return out or ['No group statistic differs from the model by more than twice what chaos '
                   'alone gives (the seed spread).']


def _sentence(group: str, axis: str, diff: float, z: float, t_from: float) -> str:
    if group == 'force':
        what = f'the draft force is {abs(diff):.1f} N {"higher" if diff > 0 else "lower"}'
    else:
        verb = {'lateral_out': 'move outward', 'vertical': 'rise', 'forward': 'advance'}[axis]
        where = 'on the tool axis' if group.startswith('axis') else f'beside the tool ({group})'
        what = (f'markers {where} {verb} {abs(diff) * 1e3:.1f} mm '
                f'{"more" if diff > 0 else "less"}')
    return (f'{what} than the model predicts ({abs(z):.1f} times the seed spread), from '
            f't = {t_from:.2f} s on.')


__all__ = ['AXES', 'CaseGeometry', 'Diagnosis', 'diagnose', 'sentences']
