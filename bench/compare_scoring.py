"""Benchmark of the paper's trajectory scoring: 15 measured x 10,000 model trajectories.

Scores every pair (DTW and nearest-point distances along the DTW path with the compiled parallel
kernel; again with the DTW distances from dtaidistance's parallel C matrix, S_sum / MAE / RMSE /
nRMSE, ranking and the N best) after a
small warm-up that loads the compiled kernel, and times the plain per-pair path on a sample for
comparison. Synthetic seeded trajectories of 45-55 points. Last line: one JSON object.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import replace

import numpy as np

from dempath_compare.config import CompareConfig, Pairing
from dempath_compare.metrics import score_pair
from dempath_compare.records import Track, pack_tracks
from dempath_compare.scoring import score_sets

N_MEASURED, N_MODEL, N_REFERENCE = 15, 10_000, 300


def walks(rng: np.random.Generator, n: int, prefix: str) -> list[Track]:
    """Seeded trajectories pushed ~0.2 m along Z with noise, 45-55 points each."""
    out = []
    for i in range(n):
        k = int(rng.integers(45, 56))
        pos = np.cumsum(rng.normal(0.0, 0.002, (k, 3)), axis=0)
        pos[:, 2] += np.linspace(0.0, 0.2, k)
        out.append(Track(f'{prefix}/{i}', prefix, i + 1, 0, np.arange(k) * 0.01, pos))
    return out


def main() -> None:
    """Run the benchmark and print the JSON summary."""
    rng = np.random.default_rng(2025)
    config = CompareConfig(pairing=Pairing.ALL, top_n=10)
    measured = pack_tracks(walks(rng, N_MEASURED, 'experiment'), shift_to_origin=True)
    model = pack_tracks(walks(rng, N_MODEL, 'model'), shift_to_origin=True)
    t0 = time.perf_counter()
    score_sets(measured, pack_tracks(walks(rng, 4, 'warm'), shift_to_origin=True), config)
    warmup_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = score_sets(measured, model, config)
    scoring_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    via_dtaidistance = score_sets(measured, model, replace(config, dtw_engine='dtaidistance'))
    dtaidistance_s = time.perf_counter() - t0
    dtw_diff = float(np.nanmax(np.abs(via_dtaidistance.scores.dtw - result.scores.dtw)))
    sample = rng.integers(0, N_MODEL, N_REFERENCE)
    t0 = time.perf_counter()
    ref = [score_pair(measured.track(0).positions, model.track(int(j)).positions, config)
           for j in sample]
    per_pair_s = (time.perf_counter() - t0) / N_REFERENCE
    diff = max(abs(r.s_sum - result.scores.s_sum[0, j]) / r.s_sum for r, j in zip(ref, sample,
                                                                                 strict=True))
    pairs = int(result.scores.compared.sum())
    print(f'scored {pairs} pairs in {scoring_s:.2f} s ({dtaidistance_s:.2f} s with the DTW '
          f"distances from dtaidistance's C matrix); "
          f'plain per-pair path {per_pair_s * 1e3:.2f} ms/pair')
    print(json.dumps({
        'scoring_s': round(scoring_s, 3), 'pairs': pairs,
        'pairs_per_s': round(pairs / scoring_s),
        'scoring_dtaidistance_engine_s': round(dtaidistance_s, 3),
        'max_abs_dtw_diff_engines_m': dtw_diff,
        'warmup_s': round(warmup_s, 3), 'reference_ms_per_pair': round(per_pair_s * 1e3, 3),
        'speedup_vs_reference': round(per_pair_s * pairs / scoring_s, 1),
        'max_rel_diff_vs_reference': float(diff), 'measured': N_MEASURED, 'model': N_MODEL,
        'points_per_trajectory': '45-55', 'cpus': os.cpu_count(),
        'load_avg_1min': round(os.getloadavg()[0], 2)}))


if __name__ == '__main__':
    main()
