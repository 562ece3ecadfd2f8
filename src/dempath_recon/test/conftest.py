"""Shared fixtures of the dempath_recon tests: the twin's true cameras and point sets."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_calib.camera import StereoCalibration
from dempath_calib.pointset import PointSet
from dempath_twin.board.recording import synthetic_point_set
from dempath_twin.rig import paper_rig


@pytest.fixture(scope='session')
def rig() -> StereoCalibration:
    """The twin's true cameras (paper intrinsics, dempath_calib poses)."""
    return paper_rig()


@pytest.fixture(scope='session')
def points() -> PointSet:
    """4,000 board-corner samples with 0.2 px corner noise (seed 1)."""
    return synthetic_point_set(4000, noise_px=0.2, seed=1)


@pytest.fixture(scope='session')
def clean_points() -> PointSet:
    """2,000 board-corner samples without pixel noise (seed 2)."""
    return synthetic_point_set(2000, noise_px=0.0, seed=2)


def split(n: int, n_test: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Random train / test row indices."""
    perm = np.random.default_rng(seed).permutation(n)
    return perm[n_test:], perm[:n_test]
