"""The faint search's contrast spots (``DetectorConfig.contrast_faint``): a marker beside a
track's prediction found by its contrast to the window's own sand, refused beside another spot
or where it shows too little of a marker; and the band-pass that only adds spots
(``DetectorConfig.band_adds_only``). Synthetic chroma for the measures, real OpenCV JPEG frames
and the real detector for the rules."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spots import CLAY, SAND, spot_image

from dempath_recon.tracking.contrast_faint import (
    FAINT_SHARE,
    ISOLATION,
    contrast_peak,
    contrast_spot,
    whole_excess,
)
from dempath_recon.tracking.covered import MIN_SPOTS
from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector

RADIUS = 3.3  # px: the bundled render's markers (6.5-6.7 px across)
SIGMA, REACH, WINDOW = 1.0, 2.0, 3.0  # the detector's at half size [px]


def faint_window(rng: np.random.Generator, contrast: float, at: tuple[float, float] = (17, 17),
                 radius: float = 0.5 * RADIUS + 0.5, noise: float = 0.02) -> np.ndarray:
    """(35, 35) chroma: sand at -0.2 with Gaussian noise of ``noise``, and a disc of
    ``radius`` px at ``at`` standing ``contrast`` above it (0: none)."""
    yy, xx = np.mgrid[0:35, 0:35]
    c = rng.normal(-0.2, noise, (35, 35))
    c[np.hypot(xx - at[0], yy - at[1]) <= radius] += contrast
    return np.asarray(c, np.float32)


def test_a_flattened_marker_stands_out_of_the_windows_own_noise() -> None:
    """A disc 0.2 above noisy sand, its chroma nowhere near the faint search's absolute bar
    (0.08), is found within a pixel of its centre from a prediction 1.5 px off; sand alone,
    and a disc of a fifth of that contrast, give nothing on any of 40 windows."""
    for seed in range(40):
        rng = np.random.default_rng(seed)
        c = faint_window(rng, 0.2)
        assert float(c.max()) < 0.08
        spot = contrast_peak(c, np.array([18.0, 16.0]), SIGMA, REACH, WINDOW)
        assert np.hypot(*(spot - 17.0)) < 1.0, f'seed {seed}: {spot}'
        for weak in (0.0, 0.04):
            nothing = contrast_peak(faint_window(rng, weak), np.array([17.0, 17.0]), SIGMA,
                                    REACH, WINDOW)
            assert not np.isfinite(nothing).any(), f'seed {seed}: a spot in the sand'


def test_a_spot_beside_another_or_showing_too_little_is_refused() -> None:
    """The same faint disc: kept with the frame's other spots far away and a whole marker's
    excess like its own; refused with a spot within ``ISOLATION`` diameters, with a whole
    marker's excess that makes its share under ``FAINT_SHARE``, and without a reference."""
    c = faint_window(np.random.default_rng(1), 0.2)
    diameter = 2 * RADIUS / 2  # [detector px]
    far = np.array([[17.0 + (ISOLATION + 0.5) * diameter, 17.0]])
    near = np.array([[17.0 + (ISOLATION - 0.5) * diameter, 17.0]])
    own = float((np.hypot(*(np.mgrid[0:35, 0:35] - 17.0)) <= 0.5 * RADIUS + 0.5).sum()) * 0.2

    def spot(others: np.ndarray, whole: float) -> np.ndarray:
        return contrast_spot(c, np.array([17.5, 17.0]), others, lambda: whole, sigma=SIGMA,
                             reach=REACH, radius=WINDOW, diameter=diameter)

    assert np.isfinite(spot(far, own)).all()
    assert not np.isfinite(spot(near, own)).any()
    assert not np.isfinite(spot(far, own / (0.8 * FAINT_SHARE))).any()
    assert not np.isfinite(spot(far, float('nan'))).any()


def test_a_whole_marker_needs_enough_spots() -> None:
    """The frame's whole-marker excess is a high percentile of its spots' (a covered one does
    not pull it down), and there is none under ``MIN_SPOTS`` spots."""
    masses = np.array([10.0, 10.5, 9.5, 10.0, 3.0, 10.2])
    assert whole_excess(masses) == pytest.approx(10.0, abs=0.3)
    assert np.isnan(whole_excess(masses[:MIN_SPOTS - 1]))


def jpeg_frame(rng: np.random.Generator, centres: np.ndarray, faint: int,
               mix: float) -> bytes:
    """JPEG 60 of blue clay discs of ``RADIUS`` at ``centres`` (n, 2) px on sand with read
    noise 6 DN, the marker ``faint`` of a colour ``mix`` of the way from the sand to the clay
    (a marker JPEG and noise flatten, or one seen through dust)."""
    h, w = 200, 320
    img = SAND[None, None, :] * rng.normal(1.0, 0.08, (h, w))[..., None]
    yy, xx = np.mgrid[0:h, 0:w]
    for k, (cx, cy) in enumerate(centres):
        colour = SAND + mix * (CLAY - SAND) if k == faint else CLAY
        img[np.hypot(xx - cx, yy - cy) <= RADIUS] = colour
    img = np.clip(170 * img + rng.normal(0, 6, img.shape), 0, 255).astype(np.uint8)
    return bytes(cv2.imencode('.jpg', img, [cv2.IMWRITE_JPEG_QUALITY, 60])[1])


def test_the_faint_search_finds_a_flattened_marker_only_with_contrast_faint() -> None:
    """Markers 45 px apart, one of them 0.55 of the way from the sand's colour to the clay's
    under JPEG 60 and noise: the detector does not find it; the faint search beside a
    prediction 2 px off finds it within 2 px with ``contrast_faint`` on every one of six
    frames, not without; beside a prediction on bare sand it finds nothing either way."""
    gx, gy = np.meshgrid(np.arange(40, 300, 45), np.arange(40, 190, 45))
    for seed in range(6):
        rng = np.random.default_rng(seed)
        centres = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-3, 3, (gx.size, 2))
        faint = 9
        jpeg = jpeg_frame(rng, centres, faint, 0.55)
        prediction = centres[faint] + np.array([2.0, 0.0])
        sand_point = centres[faint] + np.array([22.0, 0.0])
        for on in (False, True):
            found = MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS,
                                                  contrast_faint=on)).detect_jpeg(jpeg)
            assert found.faint is not None
            assert np.linalg.norm(found.uv - centres[faint], axis=1).min() > 3.0
            spots = found.faint(np.array([prediction, sand_point]), 4.0)
            assert not np.isfinite(spots[1]).any(), f'seed {seed}: a spot on bare sand'
            if on:
                assert np.linalg.norm(spots[0] - centres[faint]) < 2.0, f'seed {seed}'
            else:
                assert not np.isfinite(spots[0]).any()


def test_the_band_pass_that_only_adds_keeps_markers_among_bunched_ones() -> None:
    """Markers 1.8 diameters apart, every third 40 % under the sand: their neighbours' clay
    raises the local background, and the band-pass's bar loses more than a tenth of the
    markers over four frames; with ``band_adds_only`` it keeps 98 % or more, no spot lies off
    the markers, and every spot of the band-pass alone is kept."""
    found = {False: 0, True: 0}
    total = 0
    for seed in range(4):
        rng = np.random.default_rng(seed)
        gx, gy = np.meshgrid(np.arange(8), np.arange(6))
        pitch = 1.8 * 2 * RADIUS
        centres = np.column_stack([40 + gx.ravel() * pitch, 40 + gy.ravel() * pitch])
        centres = centres + rng.uniform(-0.5, 0.5, centres.shape)
        buried = np.where(np.arange(len(centres)) % 3 == 1, 0.4, 0.0)
        jpeg = spot_image((160, 200), centres, RADIUS, rng, noise_dn=2.0, quality=85,
                          buried=buried)
        uv = {on: MarkerDetector(DetectorConfig(marker_diameter_px=2 * RADIUS,
                                                band_adds_only=on)).detect_jpeg(jpeg).uv
              for on in (False, True)}
        for on in (False, True):
            d = np.linalg.norm(uv[on][:, None] - centres[None], axis=2)
            assert (d.min(axis=1) < 2.0).all(), f'seed {seed}: a spot off the markers'
            found[on] += int((d.min(axis=0) < 2.0).sum())
        kept = np.linalg.norm(uv[False][:, None] - uv[True][None], axis=2).min(axis=1)
        assert (kept < 0.5).all(), f'seed {seed}: a band-pass spot dropped'
        total += len(centres)
    assert found[True] >= 0.98 * total
    assert found[False] < 0.9 * total
