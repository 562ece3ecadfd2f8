"""The paper's metrics of the recalibration: Table 7 before and after, each beside the floor.

Kuře & Kuřetová 2025 (Technologies 13, 570), Table 7: per measured marker, MAE and RMSE over the
N best model trajectories and nRMSE = mean RMSE / trajectory range; then the mean nRMSE. Computed
by ``dempath_compare`` (:func:`~dempath_compare.pipeline.compare_tracks`,
:func:`~dempath_compare.summary.build_table7`) on the model runs of the scene before (the library's
baseline runs on the evaluation's seeds) and after (the recalibration's runs at the fitted
strengths on the same seeds: paired). A model trajectory is a particle starting in the marker's
cube (the paper's Cube candidates, :func:`~dempath_diagnose.decision.statistics.cube_members`).

The floor is what the true model itself gives on these metrics over packing seeds: each baseline
seed in turn plays the measurement (for every marker, the particle starting nearest the marker's
measured start, as a real marker is one grain of its cube, plus the measurement noise) and is
compared with the cube candidates of the other seeds; the floor is the mean (and sd) of those
comparisons. A mean nRMSE at the floor is all that chaos allows; the fall is judged against it,
not against zero.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dempath_diagnose.decision.statistics import Layout
from dempath_diagnose.headline.samples import MarkerSamples
from dempath_diagnose.library.counterparts import cube_members
from dempath_diagnose.records import F64, Measurement, PassRecord

TOP_N = 10  # the paper's N best model trajectories per marker


@dataclass(frozen=True)
class PaperMetrics:
    """Table 7 of one comparison.

    Attributes:
        markers: (m,) marker numbers with a row.
        mae_m, rmse_m, range_m: (m,) per marker [m] (MAE and RMSE: mean over the N best).
        nrmse: (m,) per marker [%].
        mean_nrmse: Mean over the markers [%].
        markdown: The table as dempath_compare writes it.
    """

    markers: tuple[int, ...]
    mae_m: tuple[float, ...]
    rmse_m: tuple[float, ...]
    range_m: tuple[float, ...]
    nrmse: tuple[float, ...]
    mean_nrmse: float
    markdown: str

    def to_json(self) -> dict[str, Any]:
        """Per-marker rows (mm, %) and the mean nRMSE."""
        rows = [{'marker': m, 'mae_mm': a * 1e3, 'rmse_mm': r * 1e3, 'range_mm': g * 1e3,
                 'nrmse_pct': n}
                for m, a, r, g, n in zip(self.markers, self.mae_m, self.rmse_m, self.range_m,
                                         self.nrmse, strict=True)]
        return {'mean_nrmse_pct': self.mean_nrmse, 'markers': rows}


@dataclass(frozen=True)
class PaperFloor:
    """The paper's metrics of the true model over packing seeds (leave one seed out).

    Attributes:
        mean_nrmse, mean_nrmse_sd: Mean nRMSE [%] over the seeds and its sd.
        nrmse: {marker: mean nRMSE [%] over the seeds}.
        seeds: Seeds that played the measurement.
    """

    mean_nrmse: float
    mean_nrmse_sd: float
    nrmse: dict[int, float]
    seeds: int

    def to_json(self) -> dict[str, Any]:
        """The floor for diagnosis.json."""
        return {'mean_nrmse_pct': self.mean_nrmse, 'mean_nrmse_sd_pct': self.mean_nrmse_sd,
                'seeds': self.seeds,
                'markers': [{'marker': m, 'nrmse_pct': v} for m, v in sorted(self.nrmse.items())]}


def measured_tracks(meas: Measurement, label: str = 'measured') -> list[Any]:
    """One dempath_compare Track per measured marker (finite samples only)."""
    from dempath_compare.records import Track

    out = []
    for j, m in enumerate(meas.markers):
        ok = np.isfinite(meas.positions[:, j]).all(1)
        out.append(Track(f'{label}/marker{m}', 'measured', int(m), int(m), meas.times[ok],
                         meas.positions[ok, j]))
    return out


def model_tracks(records: Sequence[tuple[str, PassRecord]], layout: Layout,
                 cube: tuple[float, float, float]) -> list[Any]:
    """The cube candidates of every measured marker in every run, as Tracks."""
    from dempath_compare.records import Track

    out = []
    for run, rec in records:
        for m, idx in zip(layout.markers, cube_members(rec.start, layout.starts, cube),
                          strict=True):
            for i in idx:
                pos = np.asarray(rec.positions[:, i], np.float64)
                ok = np.isfinite(pos).all(1)
                out.append(Track(f'{run}/{rec.ids[i]}-m{m}', run, int(rec.ids[i]), int(m),
                                 rec.times[ok], pos[ok]))
    return out


def table7(measured: Sequence[Any], model: Sequence[Any],
           markers: Sequence[int]) -> PaperMetrics:
    """Table 7 of ``measured`` against ``model`` tracks (marker pairing, the paper's top 10)."""
    from dempath_compare.config import CompareConfig, Pairing
    from dempath_compare.pipeline import compare_tracks
    from dempath_compare.summary import build_table7, table7_markdown

    config = CompareConfig(top_n=TOP_N, pairing=Pairing.MARKER, match_speed=False,
                           marker_ids=tuple(int(m) for m in markers))
    table = build_table7(compare_tracks(measured, model, config))
    rows = [r for r in table.rows if np.isfinite(r.nrmse)]
    nrmse = tuple(r.nrmse for r in rows)
    return PaperMetrics(tuple(r.marker for r in rows), tuple(r.mae_mean for r in rows),
                        tuple(r.rmse_mean for r in rows), tuple(r.range_m for r in rows),
                        nrmse, float(np.mean(nrmse)) if nrmse else float('nan'),
                        table7_markdown(table))


def nearest_tracks(rec: PassRecord, samples: MarkerSamples, noise_m: float = 0.0,
                   seed: int = 0) -> list[Any]:
    """A seed playing the measurement like for like: per measured marker, the particle starting
    nearest it, at the measured samples only (the same markers, the same window, NaN where the
    real marker was not measured), with Gaussian noise of ``noise_m`` per axis as the cameras
    add (it widens the trajectory range, the nRMSE's normaliser, of markers that barely move:
    without it the floor is too high)."""
    from dempath_diagnose.headline.samples import played_measurement

    meas = played_measurement(rec, samples, 0, noise_m, np.random.default_rng(seed))
    return measured_tracks(meas, 'pseudo')


def paper_floor(records: Sequence[tuple[str, PassRecord]], layout: Layout,
                cube: tuple[float, float, float], samples: MarkerSamples,
                noise_m: float = 0.0, pool_seeds: int | None = None) -> PaperFloor:
    """The floor on the paper's metrics (see the module docstring); needs two seeds or more.

    ``samples``: the measured markers' samples, which the seed playing the measurement keeps
    (the floor sees the markers, window and samples its figure sees); ``noise_m``: the
    measurement noise per axis added to it [m]; ``pool_seeds``: seeds in each candidate pool
    (the figure's; default every other seed).
    """
    means: list[float] = []
    per: dict[int, list[float]] = {}
    for k, (_, rec) in enumerate(records):
        others = [r for i, r in enumerate(records) if i != k][:pool_seeds]
        t = table7(nearest_tracks(rec, samples, noise_m, k), model_tracks(others, layout, cube),
                   [int(m) for m in layout.markers])
        means.append(t.mean_nrmse)
        for m, v in zip(t.markers, t.nrmse, strict=True):
            per.setdefault(m, []).append(v)
    arr: F64 = np.array(means, np.float64)
    sd = float(arr.std(ddof=1)) if len(arr) > 1 else float('nan')
    return PaperFloor(float(arr.mean()), sd, {m: float(np.mean(v)) for m, v in per.items()},
                      len(records))


def before_after(meas: Measurement, layout: Layout, cube: tuple[float, float, float],
                 before: Sequence[tuple[str, PassRecord]],
                 after: Sequence[tuple[str, PassRecord]],
                 floor_runs: Sequence[tuple[str, PassRecord]], noise_m: float = 0.0,
                 floor_after_runs: Sequence[tuple[str, PassRecord]] = (),
                 ) -> dict[str, Any]:
    """Table 7 before, after and each one's own floor, as diagnosis.json / recalibration.json
    hold them.

    ``floor_runs``: the model before (the baseline) on the seeds its floor plays;
    ``floor_after_runs``: the model after on its floor's seeds (without them the after figure
    has no floor of its own: ``floor_after`` is absent). Each floor's candidate pools hold as
    many seeds as the figure's (``before``'s), where the floor's seeds allow it.
    ``noise_m``: measurement noise per axis of the measured markers [m] (given to the floor).
    """
    measured = measured_tracks(meas)
    markers = [int(m) for m in layout.markers]
    samples = MarkerSamples.of(meas)
    b = table7(measured, model_tracks(before, layout, cube), markers)
    a = table7(measured, model_tracks(after, layout, cube), markers) if after else b
    f = paper_floor(floor_runs, layout, cube, samples, noise_m, len(before))
    out = {'before': b.to_json(), 'after': a.to_json(), 'floor': f.to_json(),
           'table7_before_md': b.markdown, 'table7_after_md': a.markdown,
           'top_n': TOP_N, 'pool_seeds': len(before),
           'floor_pool_seeds': min(len(before), len(floor_runs) - 1)}
    if after and len(floor_after_runs) > 1:
        fa = paper_floor(floor_after_runs, layout, cube, samples, noise_m, len(after))
        out['floor_after'] = fa.to_json()
        out['floor_after_pool_seeds'] = min(len(after), len(floor_after_runs) - 1)
    return out
