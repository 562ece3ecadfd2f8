"""How much better the fit of one more marker must be for a blob to be split (``split.GAIN``,
``split.EAGER_GAIN``, ``DetectorConfig.split_gain``, ``StereoTrackConfig.eager_split``)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from spots import cut_disc_patch, spot_image

from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector
from dempath_recon.tracking.split import EAGER_GAIN, GAIN, split_blob
from dempath_recon.tracking.stereo import StereoTrackConfig, camera_detectors

RADIUS = 4.0  # px: an 8 px marker
PAIR = np.array([[10.0, 12.0], [18.0, 12.0]])  # two touching markers a diameter apart [px]
BASE = 0.075  # half the detector's threshold: the blob's pixels


def shaded_pair() -> np.ndarray:
    """(24, 28) chroma of the touching pair, its right marker shaded to 0.7 of the contrast:
    neither one disc nor two fit it exactly."""
    patch = cut_disc_patch((24, 28), PAIR, (-1.0, -1.0), RADIUS)
    shade = np.where(np.arange(28)[None, :] > 14, 0.7, 1.0)
    return np.asarray(-0.2 + (patch + 0.2) * shade, np.float32)


def test_a_blob_is_split_below_the_gain_its_two_disc_fit_earns_and_not_above() -> None:
    """The gains at which the pair is split form one interval from 1 up: at a low gain both
    markers are found within 0.5 px, at a gain no fit earns the blob stays one marker."""
    patch = shaded_pair()
    gains = [1.05, 1.3, 1.7, 2.0, 3.0, 10.0, 1e3, 1e6]
    fits = [split_blob(patch, (0, 0), BASE, RADIUS, None, g) for g in gains]
    split = [f is not None for f in fits]
    assert split[0]
    assert not split[-1]
    assert split == sorted(split, reverse=True)  # once left whole, left whole at larger gains
    first = fits[0]
    assert first is not None
    assert len(first.centres) == 2
    err = np.linalg.norm(PAIR[:, None] - first.centres[None], axis=2).min(axis=1)
    assert err.max() < 0.5


def test_the_detectors_gain_reaches_the_split() -> None:
    """Two touching markers in a JPEG: split at the default gain (each within 0.6 px); at a gain
    no fit earns the detector's own two peaks are kept, pulled towards each other by more than
    1 px (``DetectorConfig.split_gain``)."""
    rng = np.random.default_rng(7)
    truth = np.array([[100.3, 80.6], [108.3, 80.6], [220.0, 160.0]])
    jpeg = spot_image((240, 320), truth, RADIUS, rng)
    split = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS)).detect_jpeg(jpeg)
    whole = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS,
                                          split_gain=99.0)).detect_jpeg(jpeg)
    for found in (split, whole):
        assert len(found.uv) == 3
    assert split.parted is not None and whole.parted is not None
    assert split.parted.sum() == 2
    assert not whole.parted.any()
    err = [np.linalg.norm(truth[:2, None] - f.uv[None], axis=2).min(axis=1).max()
           for f in (split, whole)]
    assert err[0] < 0.6
    assert err[1] > 1.0


def test_eager_split_sets_each_cameras_gain(rig) -> None:  # type: ignore[no-untyped-def]
    """``StereoTrackConfig.eager_split`` gives each camera's detector ``EAGER_GAIN`` (lower
    than ``GAIN``), off gives ``GAIN``; a gain the detector's settings give is kept."""
    assert 1.0 < EAGER_GAIN < GAIN
    cams = {c.name: c for c in rig.cameras}
    grid = MarkerGrid(layout_m=((-0.05, 0.0, -0.05), (0.05, 0.0, -0.05), (0.0, 0.0, 0.05)))
    on = camera_detectors(cams, StereoTrackConfig(grid=grid, eager_split=True))
    off = camera_detectors(cams, StereoTrackConfig(grid=grid, eager_split=False))
    own = camera_detectors(cams, StereoTrackConfig(
        grid=grid, eager_split=True, detector=DetectorConfig(split_gain=3.0)))
    assert {d.config.split_gain for d in on.values()} == {EAGER_GAIN}
    assert {d.config.split_gain for d in off.values()} == {GAIN}
    assert {d.config.split_gain for d in own.values()} == {3.0}
