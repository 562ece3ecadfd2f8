"""Group statistics on synthetic tracks with a known answer, for any marker layout."""

from __future__ import annotations

import numpy as np

from dempath_diagnose.decision.statistics import (
    build_layout,
    local_field,
    measured_statistics,
    model_statistics,
    window_means,
)
from dempath_diagnose.records import Measurement, PassRecord

CUBE = (0.02, 0.02, 0.02)


def layout_9_both_sides() -> tuple[np.ndarray, np.ndarray]:
    """Nine markers: three on the axis, three left, three right (a user's own layout)."""
    xs = np.repeat([0.0, -0.05, 0.05], 3)
    zs = np.tile([0.1, 0.15, 0.2], 3)
    starts = np.column_stack([xs, np.zeros(9), zs])
    return np.arange(1, 10), starts


def outward_motion(starts: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(nt, n, 3): beside the axis, outward at 0.1 m/s; on it, forward at 0.2 m/s."""
    side = np.where(np.abs(starts[:, 0]) > 0.01, np.sign(starts[:, 0]), 0.0)
    v = np.column_stack([0.1 * side, np.zeros(len(starts)), 0.2 * (side == 0)])
    return starts[None] + t[:, None, None] * v[None]


def test_groups_follow_the_start_positions(strict_numpy: None) -> None:
    """Axis, left and right groups from the starts; windows cover [0, end]."""
    markers, starts = layout_9_both_sides()
    lay = build_layout(markers, starts, 0.0, 0.01, 0.4, 0.3, n_windows=4)
    assert {g.name: sorted(g.members.tolist()) for g in lay.groups} == {
        'axis': [0, 1, 2], 'left': [3, 4, 5], 'right': [6, 7, 8]}
    assert lay.windows[0, 0] == 0.0 and abs(lay.windows[-1, 1] - 0.4) < 1e-12
    assert lay.force_windows == (0, 1, 2)  # the fourth window starts after the tool stopped
    assert len(lay.names(True)) == 2 * 4 + 3 * 4 * 2 + 3


def test_depth_bands_split_a_group() -> None:
    """Markers 50 mm deeper than the others of their side form a '/deep' group."""
    markers, starts = layout_9_both_sides()
    starts[8, 1] = -0.05
    lay = build_layout(markers, starts, 0.0, 0.01, 0.4, 0.3)
    assert 'right/deep' in {g.name for g in lay.groups}


def test_window_means_of_a_ramp(strict_numpy: None) -> None:
    """The time-average of v = t over [a, b] is (a + b) / 2, whatever the sampling."""
    t = np.linspace(0.0, 1.0, 7)
    windows = np.array([[0.0, 0.5], [0.5, 1.0]])
    assert np.allclose(window_means(t, t, windows), [0.25, 0.75])


def test_measured_and_model_statistics_agree_on_the_same_motion() -> None:
    """Markers and model particles moving alike: equal group statistics, the known values."""
    markers, starts = layout_9_both_sides()
    t = np.linspace(0.0, 0.4, 41)
    meas = Measurement(markers, t, outward_motion(starts, t))
    lay = build_layout(markers, starts, 0.0, 0.01, 0.4, 0.4, n_windows=2)
    y, _ = measured_statistics(meas, lay)
    rng = np.random.default_rng(0)
    particles = np.repeat(starts, 5, axis=0) + rng.uniform(-0.008, 0.008, (45, 3))
    rec = PassRecord(t, np.arange(45), outward_motion(particles, t).astype(np.float32),
                     np.zeros((41, 3)), t, np.zeros((41, 3)))
    model = model_statistics(rec, lay, CUBE, with_force=False)
    names = lay.names(False)
    assert np.allclose(model.vector, y, atol=1e-6)
    lateral = dict(zip(names, y, strict=True))
    assert abs(lateral['right:lateral_out:w1'] - 0.1 * 0.3) < 1e-6  # mean of t over [0.2, 0.4]
    assert abs(lateral['left:lateral_out:w1'] - 0.1 * 0.3) < 1e-6  # outward, signed by side
    assert abs(lateral['axis:forward:w0'] - 0.2 * 0.1) < 1e-6
    assert np.all(model.members == 5)
    assert np.allclose(model.sampling_cov, 0.0, atol=1e-12)  # every particle moves alike


def test_the_model_reads_the_field_at_the_marker_start_not_the_cube_centroid() -> None:
    """A surface marker: its cube's particles all lie below it, where the bed moves less. The
    plane through them read at the start recovers the marker's motion; the cube mean does not."""
    rng = np.random.default_rng(3)
    offsets = np.column_stack([rng.uniform(-0.02, 0.02, 40), rng.uniform(-0.03, 0.0, 40),
                               rng.uniform(-0.015, 0.015, 40)])  # the half cube below
    at_start = np.array([0.030, 0.010, 0.050])  # (lateral out, vertical, forward) [m]
    gradient = np.array([[0.2, 0.0, 0.0], [0.0, 0.3, 0.0], [0.0, 2.0, 0.5]])  # d feature/d offset
    scatter = 0.002
    f = (at_start + offsets @ gradient.T)[:, None, :] + rng.normal(0, scatter, (40, 1, 3))
    value, var, centred = local_field(f, offsets)
    assert np.allclose(value[0], at_start, atol=1.5e-3)
    assert np.abs(f.mean(0)[0] - at_start).max() > 0.02  # the cube mean is 30 mm off forward
    assert np.allclose(np.sqrt(var[0]), scatter, rtol=0.35)  # one particle's scatter
    assert np.allclose(centred.std(0, ddof=1), scatter, rtol=0.35)
    few = f[:5]
    value5, _, _ = local_field(few, offsets[:5])  # too few particles for a plane: the mean
    assert np.allclose(value5, few.mean(0))
