"""Session 22's shortcuts in detection and tracking give exactly what the plain computation
gives: one window's chroma read at two floors from one numerator, the local-maximum test read
at the candidate pixels instead of a dilation of the whole box, and pixels undistorted once per
camera."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath_calib.camera import CameraModel
from dempath_recon.methods.projection import undistort_normalized
from dempath_recon.tracking.associate import normalised
from dempath_recon.tracking.colour_model import colour_axis
from dempath_recon.tracking.detect import DetectorConfig, MarkerDetector, neighbourhood_max

RED_CLAY = (0.15, 0.18, 0.62)  # B, G, R albedo
SLATE = (0.42, 0.44, 0.47)


def plain_chroma(image: np.ndarray, floor: float, axis: np.ndarray | None) -> np.ndarray:
    """The chroma as session 21 computed it for each call (no shared parts)."""
    if axis is None:
        b, g, r = cv2.split(image)
        diff = cv2.subtract(b, r, dtype=cv2.CV_16S)
        total = cv2.add(cv2.add(b, g, dtype=cv2.CV_16S), r, dtype=cv2.CV_16S)
        np.maximum(total, np.int16(floor), out=total)
        return np.asarray(cv2.divide(diff, total, scale=1.0, dtype=cv2.CV_32F))
    pixels = image.astype(np.float32)
    num = cv2.transform(pixels, axis.reshape(1, 3))
    total = cv2.transform(pixels, np.ones((1, 3), np.float32))
    np.maximum(total, np.float32(floor), out=total)
    return np.asarray(cv2.divide(num, total))


@pytest.mark.parametrize('clay', ['blue', 'red'])
def test_one_window_read_at_two_floors_is_each_floors_chroma(clay: str) -> None:
    """Markers in a dim frame (light x0.3, noise) and one far off, so the window is a part of
    the frame: the window's chroma and the same window at a lower floor (a dim frame's
    published centres) equal the chroma of the window's pixels at each floor, bit for bit."""
    rng = np.random.default_rng(22)
    centres = np.array([[300.0, 200.0], [312.0, 203.0], [350.0, 260.0], [700.0, 420.0]])
    clay_bgr = np.array(RED_CLAY) if clay == 'red' else np.array([0.62, 0.22, 0.10])
    sand_bgr = np.array(SLATE) if clay == 'red' else np.array([0.42, 0.58, 0.72])
    jpeg = spot_image((540, 960), centres + rng.uniform(0, 1, (4, 2)), 4.5, rng, gain=0.3,
                      noise_dn=3.0, quality=85, sand_bgr=sand_bgr, clay_bgr=clay_bgr)
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    axis = None if clay == 'blue' else colour_axis(RED_CLAY, SLATE)
    detector = MarkerDetector(DetectorConfig(downscale=1))
    for floor in (60.0, 45.0):
        x0, y0, c, parts = detector._window(image, 0.15, floor, axis)
        assert 0 < c.size < image.shape[0] * image.shape[1]
        own = np.ascontiguousarray(image[y0:y0 + c.shape[0], x0:x0 + c.shape[1]])
        assert np.array_equal(c, plain_chroma(own, floor, axis))
        for lower in (23.0, 12.5):
            assert np.array_equal(parts.floored(lower), plain_chroma(own, lower, axis))


@pytest.mark.parametrize('sep', [2, 3, 5])
def test_the_neighbourhood_maximum_is_the_dilation(sep: int) -> None:
    """Every pixel of a smooth image with flat tops and ties, the four edges and corners
    included: the maximum over the ellipse's offsets equals ``cv2.dilate`` with that ellipse."""
    rng = np.random.default_rng(sep)
    image = cv2.GaussianBlur(rng.normal(0, 1, (40, 57)).astype(np.float32), (0, 0), 1.5)
    image[10:13, 20:24] = image.max()  # a plateau: ties
    image = np.round(image, 2)  # more ties
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * sep + 1, 2 * sep + 1))
    reach = tuple(np.asarray(v, np.intp) - sep for v in np.nonzero(kernel))
    rows, cols = (np.asarray(v, np.intp).ravel() for v in np.mgrid[0:40, 0:57])
    got = neighbourhood_max(image, rows, cols, reach)
    assert np.array_equal(got, cv2.dilate(image, kernel)[rows, cols])


def camera(fx: float = 1400.0) -> CameraModel:
    """A 1920x1080 camera with a strong barrel distortion."""
    k = np.array([[fx, 0, 955.0], [0, fx, 545.0], [0, 0, 1]])
    return CameraModel('cam_test', 1920, 1080, k, np.array([-0.3, 0.12, 1e-3, -5e-4, -0.02]),
                       np.eye(3), np.array([0.0, 0.0, 1.0]))


def test_pixels_undistorted_once_are_opencvs() -> None:
    """Pixels asked again (in other orders, with repeats and a missing one) give OpenCV's
    undistortion of the whole set; a camera whose intrinsics change in place is undistorted
    anew, not from the memo."""
    rng = np.random.default_rng(5)
    cam = camera()
    uv = rng.uniform([0, 0], [1920, 1080], (30, 2))
    uv[7] = np.nan
    first = normalised(cam, uv)
    assert np.array_equal(first, undistort_normalized(cam, uv), equal_nan=True)
    again = rng.permutation(np.vstack([uv, uv[:5], rng.uniform(0, 1000, (4, 2))]))
    assert np.array_equal(normalised(cam, again), undistort_normalized(cam, again),
                          equal_nan=True)
    cam.K[0, 0] = 1500.0
    assert np.array_equal(normalised(cam, uv), undistort_normalized(cam, uv), equal_nan=True)
    assert not np.allclose(normalised(cam, uv[:3]), first[:3])
