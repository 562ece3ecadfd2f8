"""Shared fixtures of the dempath_compare tests."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

EXAMPLE_DIR = Path(__file__).resolve().parents[1] / 'dempath_compare' / 'data' / 'example'


@pytest.fixture
def strict_numpy() -> Iterator[None]:
    """Numpy raises on any floating-point fault inside the test."""
    old = np.seterr(all='raise')
    try:
        yield
    finally:
        np.seterr(**old)


@pytest.fixture
def example_dir() -> Path:
    """The committed synthetic worked example (4 CSV files)."""
    return EXAMPLE_DIR
