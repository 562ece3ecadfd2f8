"""The batched fast path against the plain per-pair path, ranking, runs and the Cube region."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath_compare.config import CompareConfig, Matching, RankBy
from dempath_compare.correspondence import assign_markers, cube_candidates
from dempath_compare.kernels import pair_distances
from dempath_compare.metrics import dtw_path, score_pair
from dempath_compare.records import Track, pack_tracks
from dempath_compare.scoring import score_runs, score_sets


def random_walks(rng: np.random.Generator, n: int, prefix: str) -> list[Track]:
    """Seeded 3D walks drifting along +Z, 8-30 samples, different lengths."""
    tracks = []
    for i in range(n):
        k = int(rng.integers(8, 30))
        pos = np.cumsum(rng.normal(0.0, 0.003, (k, 3)), axis=0)
        pos[:, 2] += np.linspace(0.0, 0.15, k)
        tracks.append(Track(f'{prefix}/{i}', prefix, i + 1, 0, np.arange(k) * 0.02, pos))
    return tracks


@pytest.mark.parametrize(('matching', 'z_weight', 'engine'), [
    (Matching.DTW, 1.0, 'kernel'), (Matching.DTW, 1.0, 'dtaidistance'),
    (Matching.NEAREST, 1.0, 'kernel'), (Matching.DTW, 2.5, 'kernel')])
def test_fast_path_equals_per_pair_path(matching: Matching, z_weight: float, engine: str) -> None:
    """score_sets (compiled kernel, dtaidistance C matrix) gives the plain per-pair numbers."""
    rng = np.random.default_rng(11)
    config = CompareConfig(matching=matching, z_weight=z_weight, dtw_engine=engine)
    meas = pack_tracks(random_walks(rng, 4, 'e'), shift_to_origin=True)
    model = pack_tracks(random_walks(rng, 25, 'm'), shift_to_origin=True)
    result = score_sets(meas, model, config)
    for e in range(len(meas)):
        for m in range(len(model)):
            ref = score_pair(meas.track(e).positions, model.track(m).positions, config)
            got = result.scores
            assert got.dtw[e, m] == pytest.approx(ref.dtw, rel=1e-9)
            assert got.s_sum[e, m] == pytest.approx(ref.s_sum, rel=1e-9)
            assert got.s_mean[e, m] == pytest.approx(ref.s_mean, rel=1e-9)
            assert got.rmse[e, m] == pytest.approx(ref.rmse, rel=1e-9)


def test_kernel_dtw_equals_dtaidistance() -> None:
    """The kernel's own DTW (used for its warping path) equals dtaidistance dtw_ndim."""
    rng = np.random.default_rng(3)
    meas = pack_tracks(random_walks(rng, 3, 'e'))
    model = pack_tracks(random_walks(rng, 6, 'm'))
    pe, pm = (a.ravel().astype(np.int64) for a in np.meshgrid(range(3), range(6), indexing='ij'))
    _, _, dtw = pair_distances(np.nan_to_num(meas.positions), meas.lengths,
                               np.nan_to_num(model.positions), model.lengths, pe, pm, 1.0, True)
    ref = [dtw_path(meas.track(e).positions, model.track(m).positions)[0]
           for e, m in zip(pe, pm, strict=True)]
    np.testing.assert_allclose(dtw, ref, rtol=1e-12)


def line(offset: float, k: int, label: str, ident: int = 1) -> Track:
    """k points along Z (10 mm apart) offset across by ``offset`` [m] after the first point."""
    pos = np.zeros((k, 3))
    pos[:, 2] = np.arange(k) * 0.01
    pos[1:, 0] = offset
    return Track(label, 'g', ident, 0, np.arange(k) * 0.01, pos)


def test_ranking_by_sum_and_by_mean() -> None:
    """Ranks follow S_sum or S_mean as asked; unscored pairs get rank 0."""
    meas = pack_tracks([line(0.0, 6, 'e/marker1')], shift_to_origin=True)
    model = pack_tracks([line(0.004, 6, 'm/1'), line(0.001, 6, 'm/2'), line(0.002, 6, 'm/3')],
                        shift_to_origin=True)
    for rank_by in (RankBy.SUM, RankBy.MEAN):
        result = score_sets(meas, model, CompareConfig(rank_by=rank_by, top_n=2))
        assert result.scores.rank[0].tolist() == [3, 1, 2]
        assert result.best(0).tolist() == [1, 2]
        assert result.scores.s_mean[0, 1] == pytest.approx(0.001 * 5 / 6)


def test_score_runs_equals_separate_calls() -> None:
    """Scoring many runs in one call gives each run's own scores and ranks."""
    rng = np.random.default_rng(5)
    meas = pack_tracks(random_walks(rng, 3, 'e'), shift_to_origin=True)
    runs = {f'run{r}': pack_tracks(random_walks(rng, 7, f'run{r}'), shift_to_origin=True)
            for r in range(3)}
    joint = score_runs(meas, runs)
    for name, tset in runs.items():
        alone = score_sets(meas, tset)
        np.testing.assert_allclose(joint[name].scores.s_sum, alone.scores.s_sum)
        np.testing.assert_allclose(joint[name].scores.dtw, alone.scores.dtw)
        np.testing.assert_array_equal(joint[name].scores.rank, alone.scores.rank)


def test_cube_region_selects_candidates() -> None:
    """30 x 20 x 10 mm around (0, 0, 0): (14, 9, 4) mm inside, (16, 0, 0) and (0, 0, 6) outside."""
    marker = np.zeros((1, 3))
    particles = np.array([[0.014, 0.009, 0.004], [0.016, 0, 0], [0, 0, 0.006], [0, 0, -0.004]])
    assert cube_candidates(marker, particles).tolist() == [[True, False, False, True]]
    markers = np.array([[0.0, 0, 0], [0.05, 0, 0]])
    assigned = assign_markers(np.array([4, 5]), markers, np.array([[0.049, 0, 0], [0.2, 0, 0]]))
    assert assigned.tolist() == [5, 0]


def test_cube_pairing_end_to_end() -> None:
    """With pairing 'cube', only untagged particles starting within 15/10/5 mm of the marker's
    start are compared with it."""
    from dempath_compare.config import Pairing
    from dempath_compare.pipeline import compare_tracks

    meas = line(0.0, 6, 'e/marker3', ident=3)
    model = []
    for k, start in enumerate(([0.01, 0.0, 0.0], [0.0, 0.009, 0.004], [0.02, 0.0, 0.0],
                               [0.0, 0.0, 0.006])):
        base = line(0.001 * (k + 1), 6, f'm/{k}', ident=k)
        rest = np.repeat(base.positions[:1], 4, axis=0)
        pos = np.vstack([rest, base.positions]) + start
        model.append(Track(base.label, 'm', k, 0, np.arange(len(pos)) * 0.01, pos))
    result = compare_tracks([meas], model, CompareConfig(pairing=Pairing.CUBE))
    assert result.scores.compared[0].tolist() == [True, True, False, False]
    assert result.best(0).tolist() == [0, 1]


def test_live_comparer_equals_batch(example_dir: Path) -> None:
    """The node's streaming core, fed sample by sample, scores like the batch pipeline."""
    from dempath_compare.live import LiveComparer
    from dempath_compare.loaders import load_source
    from dempath_compare.pipeline import compare_tracks

    measured = load_source(example_dir / 'experiment_1ms.csv', 'measured')
    model = load_source(example_dir / 'model_1ms.csv', 'model')
    live = LiveComparer(CompareConfig(), experiment='experiment_1ms')
    for track in measured:
        for t, p in zip(track.times, track.positions, strict=True):
            live.add_markers(float(t), np.array([track.ident]), p[None, :])
    for track in model:
        for t, p in zip(track.times, track.positions, strict=True):
            live.add_particles('model_1ms', float(t), np.array([track.ident]),
                               np.array([track.marker_id]), p[None, :])
    streamed, batch = live.finish('model_1ms'), compare_tracks(measured, model)
    np.testing.assert_allclose(streamed.scores.s_sum, batch.scores.s_sum)
    np.testing.assert_array_equal(streamed.scores.rank, batch.scores.rank)
