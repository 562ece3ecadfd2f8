"""The whole measured pass (issue 26): a marker lost early counts where it was measured, it
never cuts the others, and the floors see the samples their figures see."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dempath_diagnose.decision.measure import load_tracks
from dempath_diagnose.decision.statistics import (
    build_layout,
    measured_statistics,
    model_statistics,
)
from dempath_diagnose.headline.samples import MarkerSamples
from dempath_diagnose.recalibration.paper_metrics import nearest_tracks
from dempath_diagnose.records import Measurement, PassRecord

LOST = (2, 3)  # markers lost at 0.28 s
STARTS = {1: (0.0, 0.0, 0.30), 2: (0.0, 0.0, 0.35), 3: (0.0, 0.0, 0.40), 4: (0.05, 0.0, 0.30),
          5: (0.05, 0.0, 0.35)}


def _csv(path: Path) -> Path:
    """Five markers rising over 0.6 s; markers 2 and 3 lost from 0.28 s on."""
    lines = ['t,marker,x,y,z']
    for t in np.arange(0.0, 0.6001, 0.02):
        for m, (x, y, z) in STARTS.items():
            if m in LOST and t > 0.28:
                continue
            lines.append(f'{t:.3f},{m},{x:.4f},{y + 0.05 * t * m:.5f},{z + 0.1 * t:.5f}')
    path.write_text('\n'.join(lines) + '\n')
    return path


def test_a_marker_lost_early_never_cuts_the_pass(tmp_path: Path) -> None:
    """The common time base runs to the last measured sample; lost markers are NaN after."""
    meas = load_tracks(_csv(tmp_path / 'm.csv'))
    assert meas.times[-1] > 0.59  # the old code ended every marker at 0.28 s
    lost = np.isin(meas.markers, LOST)
    late = meas.times > 0.29
    assert np.isnan(meas.positions[late][:, lost]).all()
    assert np.isfinite(meas.positions[late][:, ~lost]).all()


def _model(times: np.ndarray) -> PassRecord:
    """Particles around each marker start: marker m's cube rises 0.05 m/s x m (as the
    measurement), so each marker's field is told apart from its neighbours'."""
    rng = np.random.default_rng(1)
    pos = []
    for m, s in STARTS.items():
        start = np.asarray(s) + rng.uniform(-0.004, 0.004, (20, 3))
        p = start[None] + np.zeros((len(times), 20, 3))
        p[..., 1] += 0.05 * m * times[:, None]
        p[..., 2] += 0.1 * times[:, None]
        pos.append(p)
    arr = np.concatenate(pos, axis=1)
    return PassRecord(times, np.arange(arr.shape[1]), arr.astype(np.float32),
                      np.zeros((len(times), 3)), times, np.zeros((len(times), 3)))


def test_group_statistics_count_a_marker_where_it_was_measured(tmp_path: Path) -> None:
    """In the windows after 0.28 s the group statistic is the mean of the markers present, in
    the measurement and in the model alike, so both agree."""
    meas = load_tracks(_csv(tmp_path / 'm.csv'))
    layout = build_layout(meas.markers, meas.start, 0.0, 0.01, float(meas.times[-1]), 0.6, 4,
                          measured=meas)
    present = layout.presence()
    lost = np.isin(layout.markers, LOST)
    assert not present[lost, -1].any() and present[~lost].all()
    y, _ = measured_statistics(meas, layout)
    model = model_statistics(_model(np.linspace(0.0, 0.62, 32)), layout, (0.01, 0.01, 0.01),
                             with_force=False)
    names = layout.names(False)
    last = [i for i, n in enumerate(names) if n.startswith('axis:vertical:w3')]
    assert np.allclose(y[last], model.vector[last], atol=1e-3)


def test_the_paper_floor_sees_the_measured_samples(tmp_path: Path) -> None:
    """The seed playing the measurement in Table 7's floor has the measured markers, window
    and samples: a marker lost at 0.28 s ends there in the floor too."""
    meas = load_tracks(_csv(tmp_path / 'm.csv'))
    rec = _model(np.linspace(0.0, 0.82, 42))
    tracks = nearest_tracks(rec, MarkerSamples.of(meas), 0.0015, 0)
    assert sorted(int(t.marker_id) for t in tracks) == sorted(STARTS)
    for t in tracks:
        end = 0.28 if t.marker_id in LOST else 0.6
        assert abs(float(t.times[-1]) - end) < 0.006, (t.marker_id, t.times[-1])


def test_measurement_record_marks_unseen_samples() -> None:
    """MarkerSamples.of keeps exactly the finite samples."""
    pos = np.zeros((3, 2, 3))
    pos[2, 1] = np.nan
    s = MarkerSamples.of(Measurement(np.array([1, 2]), np.arange(3.0), pos))
    assert s.present.tolist() == [[True, True], [True, True], [True, False]]
