"""Does a fitted strength's uncertainty mean what it says? A check on the library's own runs.

Leave one packing seed out: the emulator is built from the library's other seeds, and every run
of the left-out seed (the baseline and each candidate at each strength) is turned into a
*measurement* as a camera pair would give it: for each marker of the layout, the one particle
nearest to the marker's start, with ``noise_m`` of Gaussian noise per axis and frame, and the
tool force of that run. Each is diagnosed for its own candidate, and the fitted strength is
compared with the strength the run really had: z = (fitted - true) / reported sd (on the log
axis for log-scale effects). Calibrated uncertainties give z of mean about 0 and RMS about 1;
an RMS well above 1 means over-confident strengths, a mean away from 0 a biased fit.

This is the check that found the cube-mean counterpart's bias (hidden tool speeds fitted too
far from the scene's value; :mod:`.statistics`). Its limits: the left-out runs
share the library's bed preparation and engine, so it measures chaos and the emulator, not a
lab's or another engine's systematic difference (the discrepancy allowance covers those), and
the emulator is built from one seed fewer than a diagnosis uses. No simulation runs here.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, replace

import numpy as np

from dempath_diagnose.decision.emulator import Allowance, build_emulator
from dempath_diagnose.decision.statistics import Layout, build_layout, measured_statistics
from dempath_diagnose.decision.verdict import fit_candidate
from dempath_diagnose.library.store import Library
from dempath_diagnose.records import F64, Measurement, PassRecord
from dempath_sim.effects.candidates import LOG_SCALE


@dataclass(frozen=True)
class StrengthCheck:
    """One left-out run diagnosed for one candidate.

    Attributes:
        candidate: The candidate's effect name.
        seed: The left-out packing seed.
        true: The strength the run had (the scene's value for a baseline run).
        fitted, sd: The fitted strength and its reported uncertainty.
        with_force: Whether the draft force was part of the measurement.
    """

    candidate: str
    seed: int
    true: float
    fitted: float
    sd: float
    with_force: bool

    @property
    def z(self) -> float:
        """(fitted - true) / sd, on the log axis for log-scale effects."""
        if self.candidate in LOG_SCALE:
            return float(np.log(self.fitted / self.true) / (self.sd / self.fitted))
        return (self.fitted - self.true) / self.sd


def measured_like(rec: PassRecord, starts: F64, layout: Layout, noise_m: float,
                  rng: np.random.Generator) -> F64:
    """The statistic vector (with the force) a camera pair would give of run ``rec``: the
    particle nearest each marker start, with ``noise_m`` per axis, read as a measurement."""
    nearest = [int(np.argmin(np.linalg.norm(rec.start - p, axis=1))) for p in starts]
    pos = rec.positions[:, nearest].astype(np.float64)
    meas = Measurement(layout.markers, rec.times, pos + rng.normal(0.0, noise_m, pos.shape),
                       rec.force_times, rec.tool_force)
    return measured_statistics(meas, replace(layout, starts=rec.start[nearest]))[0]


def strength_checks(library: Library, markers: F64, starts: F64, tool_x_m: float,
                    axis_half_width_m: float, cube_m: tuple[float, float, float],
                    allowance: Allowance | None = None, n_windows: int = 4,
                    rng_seed: int = 5) -> list[StrengthCheck]:
    """Every left-out run diagnosed for its candidate (baseline runs for every candidate)."""
    allowance = allowance or Allowance()
    rng = np.random.default_rng(rng_seed)
    first = next(iter(library.records.values()))
    end = float(first.times[-1])
    stop = float(first.meta.get('tool_stop_s', end))
    out = []
    for seed in library.seeds():
        keep = [r for r in library.runs if r.seed != seed]
        fold = Library(library.folder, library.candidates, keep,
                       {r.filename: library.records[r.filename] for r in keep})
        base = next(library.records[r.filename] for r in library.runs
                    if r.seed == seed and r.candidate == '')
        near = base.start[[int(np.argmin(np.linalg.norm(base.start - p, axis=1)))
                           for p in starts]]
        layout = build_layout(markers.astype(np.int64), near, tool_x_m, axis_half_width_m,
                              end, stop, n_windows)
        emu = build_emulator(fold, layout, cube_m)
        cov = emu.fixed_cov(allowance, layout)
        force = emu.is_force()
        for run in (r for r in library.runs if r.seed == seed):
            y = measured_like(library.records[run.filename], near, layout, allowance.noise_m, rng)
            for with_force in (True, False):
                obs = np.ones(len(emu.names), bool) if with_force else ~force
                for ce in emu.candidates:
                    c = ce.candidate
                    if run.candidate not in (c.name, ''):
                        continue
                    fit = fit_candidate(emu, ce, y[obs], obs, cov)
                    true = run.strength if run.candidate else c.current
                    out.append(StrengthCheck(c.name, seed, true, fit.strength, fit.strength_sd,
                                             with_force))
    return out


def summary(checks: list[StrengthCheck]) -> dict[str, dict[str, float]]:
    """Per candidate (and ``all``): n, mean z, RMS z and the fraction with |z| > 2."""
    groups: dict[str, list[float]] = defaultdict(list)
    for c in checks:
        groups[c.candidate].append(c.z)
        groups['all'].append(c.z)
    return {name: {'n': len(zs), 'mean_z': round(float(np.mean(zs)), 3),
                   'rms_z': round(float(np.sqrt(np.mean(np.square(zs)))), 3),
                   'beyond_2sd': round(float(np.mean(np.abs(zs) > 2.0)), 3)}
            for name, zs in groups.items()}
