"""A spot's seen share from its chroma flux over the local sand (``tracking.seen_flux``), and
the partly covered markers' centres it places (``DetectorConfig.flux_share``; real OpenCV,
JPEG)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_covered import RADIUS, UP, frame, miss

from dempath_recon.tracking.covered import seen_share
from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector
from dempath_recon.tracking.seen_flux import spot_flux
from dempath_recon.tracking.stereo import flux_moved

SAND, CLAY = -0.2, 0.5  # chroma of the sand and of a marker [-]


def chroma(centres: np.ndarray, radius: float, cut: np.ndarray, shape: tuple[int, int] = (40, 80),
           ) -> np.ndarray:
    """(h, w) sand's chroma with discs of ``radius`` [px] at ``centres`` (n, 2), each seen
    above ``cut`` (n,) [px below its centre; inf: whole], on 4 x 4 sub-pixels a pixel."""
    sub = 4
    h, w = shape
    ys, xs = np.mgrid[0:h * sub, 0:w * sub]
    x, y = (xs + 0.5) / sub - 0.5, (ys + 0.5) / sub - 0.5
    img = np.full(x.shape, SAND)
    for (cx, cy), c in zip(centres, cut, strict=True):
        img[(np.hypot(x - cx, y - cy) < radius) & (y - cy < c)] = CLAY
    return img.reshape(h, sub, w, sub).mean(axis=(1, 3)).astype(np.float32)


def test_flux_is_the_seen_area_times_the_contrast() -> None:
    """A whole disc's flux over the sand is its area times the clay's contrast; a disc cut at
    its centre gives half of it; a spot whose ring leaves the window gives NaN."""
    centres = np.array([[15.3, 20.2], [40.6, 19.7], [65.1, 20.4], [1.0, 20.0]])
    img = chroma(centres, 4.0, np.array([np.inf, 0.0, 2.0, np.inf]))
    flux = spot_flux(img, centres, 4.0)
    whole = np.pi * 16.0 * (CLAY - SAND)
    assert flux[0] == pytest.approx(whole, rel=0.02)
    assert flux[1] / flux[0] == pytest.approx(0.5, abs=0.02)
    assert 0.5 < flux[2] / flux[0] < 1.0
    assert np.isnan(flux[3])


def test_share_relative_to_the_frames_whole_markers() -> None:
    """Among whole markers, a disc cut at its centre reads half seen, whole ones whole."""
    centres = np.array([[10.0 + 12 * k + 0.3 * k, 20.0] for k in range(6)])
    cut = np.array([np.inf, np.inf, 0.0, np.inf, np.inf, np.inf])
    share = seen_share(spot_flux(chroma(centres, 3.5, cut), centres, 3.5), None)
    assert share is not None
    assert share[2] == pytest.approx(0.5, abs=0.04)
    assert np.allclose(np.delete(share, 2), 1.0, atol=0.03)


@pytest.mark.parametrize('buried', [0.3, 0.45, 0.55])
def test_flux_places_covered_markers_nearer_their_centre(buried: float) -> None:
    """Markers with 30-55 % of their height under the sand, among whole ones: the centres the
    flux's share places lie nearer the true centres than the centroid mass's, by 0.05 px or
    more on average over three frames, whole markers' no farther; ``centre`` itself is the
    mass's, as without the flux."""
    config = DetectorConfig(marker_diameter_px=2 * RADIUS, up_px=UP)
    mass_det = MarkerDetector(config)
    flux_det = MarkerDetector(DetectorConfig(**{**config.__dict__, 'flux_share': True}))
    gains, whole = [], []
    for seed in (3, 4, 5):
        truth, covered, jpeg = frame(seed, buried)
        mass, flux = mass_det.detect_jpeg(jpeg), flux_det.detect_jpeg(jpeg)
        assert mass.flux_shift is None and flux.flux_shift is not None
        assert flux.centre is not None and np.array_equal(flux.centre, mass.centre)
        by_mass = miss(flux.centre, truth)
        by_flux = miss(flux.centre + flux.flux_shift, truth)
        gains.append(by_mass[covered].mean() - by_flux[covered].mean())
        whole.append(by_flux[~covered].mean() - by_mass[~covered].mean())
    assert np.mean(gains) > 0.05, f'covered markers {np.mean(gains):.3f} px nearer'
    assert max(whole) < 0.02


def test_published_points_take_the_flux_shift() -> None:
    """``flux_moved``: each tracked point that is a detection goes out at its centre plus the
    flux's shift; None where the detections carry no shift."""
    _, _, jpeg = frame(3, 0.5)
    det = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS, up_px=UP,
                                        flux_share=True)).detect_jpeg(jpeg)
    assert det.centre is not None and det.flux_shift is not None
    uv = det.uv[::2]
    moved = flux_moved(det, uv)
    assert moved is not None
    assert np.allclose(moved, (det.centre + det.flux_shift)[::2])
    assert flux_moved(det._replace(flux_shift=None), uv) is None
    assert np.abs(det.flux_shift).max() > 0.05  # some covered marker moved
