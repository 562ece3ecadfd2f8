"""Start of motion (eq. 1), end trimming and the shift to the origin on hand-made trajectories."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_compare.config import CompareConfig
from dempath_compare.preprocess import (
    motion_start_index,
    motion_threshold,
    prepare_set,
    prepare_track,
    trim_end_index,
)
from dempath_compare.records import MEASURED, MODEL, Track


def test_threshold_is_mean_plus_sp_std(strict_numpy: None) -> None:
    """Rest v_z = (1, 3) m/s -> mean 2, std 1: v_thr = 2 + 2 * 1 = 4 for sp = 2."""
    t = np.array([0.0, 1.0, 2.0])
    z = np.array([0.0, 1.0, 4.0])
    assert motion_threshold(t, z, sp=2.0, rest_samples=3) == pytest.approx(4.0)


def test_start_index_and_sensitivity(strict_numpy: None) -> None:
    """Velocities (1, 3, 5, 10): sp 2 -> v_thr 4 -> start at sample 2; sp 5 -> 7 -> sample 3."""
    t = np.arange(5.0)
    z = np.cumsum([0.0, 1.0, 3.0, 5.0, 10.0])
    assert motion_start_index(t, z, 2.0, 3) == 2
    assert motion_start_index(t, z, 5.0, 3) == 3
    assert motion_start_index(t, z, 50.0, 3) is None


def test_trim_end_on_y_drop(strict_numpy: None) -> None:
    """Y rises to 5 then falls: a 1.5 drop limit keeps the samples up to Y = 4."""
    y = np.array([0.0, 2.0, 5.0, 4.0, 3.0, 1.0])
    assert trim_end_index(y, 1.5) == 4
    assert trim_end_index(y, 10.0) == 6


def test_model_cut_at_start_and_shifted(strict_numpy: None) -> None:
    """A model resting 4 samples at (1, 2, 3) then moving: starts at its last rest sample, at 0."""
    t = np.arange(8) * 0.1
    z = np.array([3.0, 3.0, 3.0, 3.0, 3.1, 3.2, 3.3, 3.4])
    pos = np.stack([np.ones(8), 2 * np.ones(8), z], axis=1)
    tset = prepare_set([Track('m/1', 'm', 1, 0, t, pos)], MODEL, CompareConfig(rest_samples=3))
    assert tset.lengths[0] == 5
    np.testing.assert_allclose(tset.positions[0, 0], 0.0)
    np.testing.assert_allclose(tset.positions[0, :5, 2], [0.0, 0.1, 0.2, 0.3, 0.4], atol=1e-12)
    np.testing.assert_allclose(tset.origins[0], [1.0, 2.0, 3.0])
    np.testing.assert_allclose(tset.times[0, :5], t[3:])


def test_measured_trimmed_only_when_asked(strict_numpy: None) -> None:
    """Measured data keep their start; the Y-drop trimming applies only with trim_y_drop set."""
    t = np.arange(6) * 0.02
    pos = np.array([[0, 0, 0], [0, 1, 1], [0, 2, 2], [0, 1.5, 3], [0, 0.5, 4], [0, 0, 5.0]]) / 100
    track = Track('e/marker3', 'e', 3, 3, t, pos)
    assert len(prepare_track(track, MEASURED, CompareConfig()).times) == 6
    trimmed = prepare_track(track, MEASURED, CompareConfig(trim_y_drop=0.01))
    assert len(trimmed.times) == 4
    assert 'trimmed' in trimmed.note
