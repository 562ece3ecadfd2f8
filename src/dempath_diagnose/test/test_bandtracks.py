"""A model band as Tracks and the paper's Table 7 against synthetic markers with a known answer."""

from __future__ import annotations

import numpy as np

from dempath_diagnose.decision.bandtracks import band_table7, band_tracks
from dempath_diagnose.records import Measurement, PassRecord

CUBE = (0.02, 0.02, 0.02)
TIMES = np.arange(0.0, 0.5 + 1e-9, 0.02)
STARTS = np.array([[0.0, 0.0, 0.1], [0.1, 0.0, 0.1]])


def paths(starts: np.ndarray, rise: float = 0.0) -> np.ndarray:
    """(nt, n, 3): at rest for 0.1 s, then marker 1's side moves forward (Z) at 0.2 m/s and
    marker 2's side outward, up and forward at 0.1, 0.05, 0.05 m/s; plus ``rise`` m/s up."""
    moving = np.clip(TIMES - 0.1, 0.0, None)[:, None, None]
    v = np.where(starts[:, :1] < 0.05, [0.0, 0.0, 0.2], [0.1, 0.05, 0.05]) + np.array([0, rise, 0])
    return starts[None] + moving * v[None]


def band(rise: float, seeds: int = 2) -> list[PassRecord]:
    """Runs with three particles in each marker's cube (2-3 mm off its start) and one far away,
    moving like the markers and rising ``rise`` m/s more."""
    offsets = np.array([[0.002, 0.0, 0.0], [0.0, -0.003, 0.0], [0.0, 0.0, 0.002]])
    starts = np.concatenate([STARTS[0] + offsets, STARTS[1] + offsets, [[0.05, 0.0, 0.3]]])
    out = []
    for s in range(seeds):
        pos = paths(starts, rise).astype(np.float32)
        out.append(PassRecord(TIMES, np.arange(len(starts)) + 100 * s, pos,
                              np.zeros((len(TIMES), 3)), TIMES, np.zeros((len(TIMES), 3)),
                              {'seed': 1001 + s}))
    return out


def measurement() -> Measurement:
    """The two markers on the same time base as the runs."""
    return Measurement(np.array([1, 2]), TIMES, paths(STARTS))


def test_band_tracks_are_each_markers_cube_candidates() -> None:
    """Three candidates per marker and run, tagged with the marker; the far particle is none."""
    tracks = band_tracks(band(0.0), [1, 2], STARTS, CUBE, names=['a', 'b'])
    assert len(tracks) == 2 * 2 * 3
    assert sorted({t.marker_id for t in tracks}) == [1, 2]
    assert all(t.ident % 100 != 6 for t in tracks)  # particle 6 starts 0.2 m away
    assert {t.run_id for t in tracks} == {'a', 'b'} and {t.seed for t in tracks} == {1001, 1002}
    assert len({t.label for t in tracks}) == len(tracks)


def test_table7_is_zero_for_a_band_that_moves_like_the_markers() -> None:
    """Candidates with the markers' own displacements: MAE, RMSE and nRMSE 0 for every marker."""
    table = band_table7(measurement(), band(0.0), CUBE)
    assert [r['marker'] for r in table['rows']] == [1, 2]
    assert all(r['n_best'] == 6 for r in table['rows'])  # 3 candidates x 2 runs
    assert table['mean_nrmse_pct'] < 1e-3
    assert not table['unscored']


def test_table7_grows_with_the_models_error() -> None:
    """Candidates rising 0.05 m/s more than the markers: a nRMSE of several per cent, larger
    when they rise 0.1 m/s more."""
    a = band_table7(measurement(), band(0.05), CUBE)['mean_nrmse_pct']
    b = band_table7(measurement(), band(0.1), CUBE)['mean_nrmse_pct']
    assert 3.0 < a < b, (a, b)
