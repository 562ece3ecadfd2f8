"""Marker-id matching of two synchronised camera frames (the stamps: dempath/test/test_sync.py)."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_recon.errors import PixelInputError
from dempath_recon.pairing import FRONT, SIDE, PixelFrame, match_ids


def test_match_ids_counts_rejections() -> None:
    """Ids seen by one camera only and duplicated ids are dropped with their reason."""
    side = PixelFrame(SIDE, 0.0, np.array([1, 2, 3, 3, 7]), np.arange(10.0).reshape(5, 2))
    front = PixelFrame(FRONT, 0.001, np.array([2, 1, 3, 9]), 100 + np.arange(8.0).reshape(4, 2))
    pair = match_ids(side, front)
    assert list(pair.ids) == [1, 2]
    assert np.allclose(pair.pixels, [[0, 1, 102, 103], [2, 3, 100, 101]])
    assert pair.rejected == {'duplicate marker id': 2, 'marker seen by one camera only': 3}


def test_bad_frames_and_settings_are_refused() -> None:
    """Mismatched ids/points, unknown camera and negative slop raise with the field named."""
    with pytest.raises(PixelInputError, match='marker ids but'):
        PixelFrame(SIDE, 0.0, np.array([1, 2]), np.zeros((3, 2)))
    with pytest.raises(PixelInputError, match='camera'):
        PixelFrame(5, 0.0, np.array([1]), np.zeros((1, 2)))
