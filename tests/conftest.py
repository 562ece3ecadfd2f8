"""Fixtures shared by the cross-package tests (opt-in, so other tests keep numpy's defaults)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest


@pytest.fixture
def strict_numpy() -> Iterator[None]:
    """Numpy raises on overflow and invalid operations, except where the code says otherwise."""
    old = np.seterr(all='raise', under='ignore')
    yield
    np.seterr(**old)
