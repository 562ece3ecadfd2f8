"""Scoring of many experiment-model pairs in one call, ranking and the N best.

The nearest-point distances come from the compiled, parallel kernel in
:mod:`dempath_compare.kernels`, which also builds each pair's DTW matrix for the warping path and
so returns the DTW distance as well (equal to dtaidistance ``dtw_ndim``, tested). With
``dtw_engine='dtaidistance'``, or with spatial matching, the DTW distances come from
dtaidistance's C implementation (``dtw_ndim.distance_matrix_fast``, OpenMP-parallel, one block per
experiment). There is no Python loop over pairs.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from operator import itemgetter

import numpy as np
from numpy.typing import NDArray

from dempath_compare.config import CompareConfig, DtwEngine, Matching, Pairing, RankBy
from dempath_compare.metrics import trajectory_range
from dempath_compare.records import TrajectorySet, concat_sets

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ScoreMatrix:
    """Scores of every (experiment, model) pair; NaN where a pair was not compared.

    Attributes:
        dtw: (n_e, n_m) DTW distance [m].
        s_sum: (n_e, n_m) S_sum [m].
        s_mean: (n_e, n_m) S_mean = MAE [m].
        rmse: (n_e, n_m) RMSE [m].
        compared: (n_e, n_m) True where the pair was scored.
        ranges: (n_e,) range of each measured trajectory [m].
        rank: (n_e, n_m) 1 = best per experiment, 0 = not ranked.
    """

    dtw: NDArray[np.float64]
    s_sum: NDArray[np.float64]
    s_mean: NDArray[np.float64]
    rmse: NDArray[np.float64]
    compared: NDArray[np.bool_]
    ranges: NDArray[np.float64]
    rank: NDArray[np.int64]

    @property
    def nrmse(self) -> NDArray[np.float64]:
        """(n_e, n_m) nRMSE = RMSE / range * 100 [%]."""
        with np.errstate(divide='ignore', invalid='ignore'):
            return np.asarray(self.rmse / self.ranges[:, None] * 100.0)

    def columns(self, index: slice | NDArray[np.int64]) -> ScoreMatrix:
        """The scores of a subset of model trajectories (e.g. one run of many)."""
        return ScoreMatrix(self.dtw[:, index], self.s_sum[:, index], self.s_mean[:, index],
                           self.rmse[:, index], self.compared[:, index], self.ranges,
                           self.rank[:, index])


@dataclass(frozen=True)
class CompareResult:
    """One comparison: the prepared sets, their scores and the settings used."""

    measured: TrajectorySet
    model: TrajectorySet
    scores: ScoreMatrix
    config: CompareConfig

    def best(self, e: int, n: int | None = None) -> NDArray[np.int64]:
        """Model indices of the ``n`` (default ``top_n``) best matches of experiment ``e``."""
        n = self.config.top_n if n is None else n
        rank = self.scores.rank[e]
        order = np.argsort(np.where(rank > 0, rank, np.iinfo(np.int64).max), kind='stable')
        return np.asarray(order[: min(n, int((rank > 0).sum()))], dtype=np.int64)


def pair_mask(measured: TrajectorySet, model: TrajectorySet,
              config: CompareConfig) -> NDArray[np.bool_]:
    """(n_e, n_m) which pairs to compare (both valid, and the pairing rule of the config)."""
    mask = measured.valid[:, None] & model.valid[None, :]
    pairing = config.pairing
    if pairing is Pairing.AUTO:
        pairing = Pairing.MARKER if np.any(model.marker_ids > 0) else Pairing.ALL
    if pairing is Pairing.MARKER:
        mask &= model.marker_ids[None, :] == measured.idents[:, None]
    elif pairing is Pairing.CUBE:
        from dempath_compare.correspondence import cube_candidates

        mask &= cube_candidates(measured.origins, model.origins, config.cube_size)
    if config.match_speed:
        mask &= same_speed(measured.speeds, model.speeds)
    mask &= same_scene(measured.scene_keys, model.scene_keys)
    return np.asarray(mask)


def same_scene(keys_e: Sequence[str], keys_m: Sequence[str]) -> NDArray[np.bool_]:
    """(n_e, n_m) False only where both scene keys are known (not '') and differ."""
    ke = np.asarray(list(keys_e), dtype=object)[:, None]
    km = np.asarray(list(keys_m), dtype=object)[None, :]
    return np.asarray((ke == km) | (ke == '') | (km == ''), dtype=bool).reshape(len(keys_e),
                                                                               len(keys_m))


def same_speed(speeds_e: NDArray[np.float64], speeds_m: NDArray[np.float64]
               ) -> NDArray[np.bool_]:
    """(n_e, n_m) False only where both tool speeds [m/s] are known (not NaN) and differ."""
    se, sm = np.asarray(speeds_e)[:, None], np.asarray(speeds_m)[None, :]
    return np.asarray((se == sm) | np.isnan(se) | np.isnan(sm))


def dtw_distances(measured: TrajectorySet, model: TrajectorySet,
                  mask: NDArray[np.bool_]) -> NDArray[np.float64]:
    """(n_e, n_m) DTW [m] of the masked pairs (dtaidistance C, parallel), NaN elsewhere."""
    from dtaidistance import dtw_ndim

    out = np.full(mask.shape, np.nan)
    model_series = model.positions_list(range(len(model)))
    for e in np.flatnonzero(mask.any(axis=1)):
        cols = np.flatnonzero(mask[e])
        picked = itemgetter(*cols)(model_series) if len(cols) > 1 else (model_series[cols[0]],)
        series = [*measured.positions_list([e]), *picked]
        block = ((0, 1), (1, len(series)), False)
        out[e, cols] = dtw_ndim.distance_matrix_fast(series, ndim=3, block=block, compact=True,
                                                     parallel=True)
    return out


def rank_scores(key: NDArray[np.float64], compared: NDArray[np.bool_]) -> NDArray[np.int64]:
    """(n_e, n_m) rank per experiment by ascending ``key`` among compared pairs (1 = best)."""
    masked = np.where(compared, key, np.inf)
    order = np.argsort(masked, axis=1, kind='stable')
    rank = np.zeros(key.shape, dtype=np.int64)
    rows = np.arange(key.shape[0])[:, None]
    rank[rows, order] = np.arange(1, key.shape[1] + 1)[None, :]
    return np.asarray(np.where(compared, rank, 0), dtype=np.int64)


def score_sets(measured: TrajectorySet, model: TrajectorySet,
               config: CompareConfig | None = None) -> CompareResult:
    """Score every allowed pair of prepared (origin-shifted) measured and model trajectories.

    Args:
        measured: prepared measured set (n_e trajectories).
        model: prepared model set (n_m trajectories).
        config: settings; defaults of the paper when None.

    Returns:
        The :class:`CompareResult` with (n_e, n_m) scores and ranks.
    """
    from dempath_compare.kernels import pair_distances

    config = config or CompareConfig()
    mask = pair_mask(measured, model, config)
    pair_e, pair_m = (np.asarray(a, dtype=np.int64) for a in np.nonzero(mask))
    shape = mask.shape
    s_sum, s_mean, rmse, dtw = (np.full(shape, np.nan) for _ in range(4))
    use_path = config.matching is Matching.DTW
    if len(pair_e):
        sums, squares, dtw_kernel = pair_distances(
            np.nan_to_num(measured.positions), measured.lengths,
            np.nan_to_num(model.positions), model.lengths, pair_e, pair_m,
            float(config.z_weight), use_path)
        count = measured.lengths[pair_e].astype(np.float64)
        s_sum[pair_e, pair_m] = sums
        s_mean[pair_e, pair_m] = sums / count
        rmse[pair_e, pair_m] = np.sqrt(squares / count)
        dtw[pair_e, pair_m] = dtw_kernel
    if not use_path or config.dtw_engine is DtwEngine.DTAIDISTANCE:
        dtw = dtw_distances(measured, model, mask)
    ranges = np.array([trajectory_range(measured.positions[e, : measured.lengths[e]],
                                        config.range_kind) if measured.lengths[e] else np.nan
                       for e in range(len(measured))]).reshape(len(measured))
    key = s_sum if config.rank_by is RankBy.SUM else s_mean
    rank = rank_scores(key, mask)
    log.info('scored %d pairs (%d measured x %d model)', len(pair_e), *shape)
    scores = ScoreMatrix(dtw, s_sum, s_mean, rmse, mask, ranges, rank)
    return CompareResult(measured, model, scores, config)


def score_runs(measured: TrajectorySet, runs: Mapping[str, TrajectorySet],
               config: CompareConfig | None = None) -> dict[str, CompareResult]:
    """Score many model runs against the same measured set in one batched call.

    The runs are stacked, scored together (one kernel launch) and split back; each run is ranked
    on its own. This is the entry point for callers that compare dozens of simulation runs.

    Args:
        measured: prepared measured set.
        runs: run id -> prepared model set.
        config: settings; defaults of the paper when None.

    Returns:
        run id -> :class:`CompareResult` of that run alone.
    """
    config = config or CompareConfig()
    names = list(runs)
    joint = score_sets(measured, concat_sets([runs[n] for n in names]), config)
    results: dict[str, CompareResult] = {}
    start = 0
    for name in names:
        cols = slice(start, start + len(runs[name]))
        start = cols.stop
        part = joint.scores.columns(cols)
        key = part.s_sum if config.rank_by is RankBy.SUM else part.s_mean
        part = ScoreMatrix(part.dtw, part.s_sum, part.s_mean, part.rmse, part.compared,
                           part.ranges, rank_scores(key, part.compared))
        results[name] = CompareResult(measured, runs[name], part, config)
    return results
