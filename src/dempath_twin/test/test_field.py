"""Tests of the field twin: trajectories -> clicked pixels of the twin cameras -> bag messages."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from dempath import topics
from dempath.bagio import open_bag, write_bag
from dempath.typestore import make_typestore
from dempath_twin.errors import TwinError
from dempath_twin.field import markers as ft
from dempath_twin.rig import paper_rig


def lifted_grid(times: np.ndarray) -> ft.MarkerTracks:
    """A 3 x 5 grid (50 mm) in scene coordinates, lifted and pushed along +Z over time."""
    col, row = np.meshgrid(np.arange(5), np.arange(3))
    start = np.stack([row.ravel() * 0.05, np.zeros(15), 0.35 + col.ravel() * 0.05], 1)
    motion = np.stack([np.zeros_like(times), 0.03 * times, 0.2 * times], 1)
    return ft.MarkerTracks(times, np.arange(1, 16, dtype=np.int32),
                           start[None] + motion[:, None])


def write_csv(path: Path, tracks: ft.MarkerTracks) -> Path:
    """Trajectories in the measured CSV shape, scene times kept."""
    lines = ['t,marker,x,y,z']
    for k, t in enumerate(tracks.times):
        for m, marker in enumerate(tracks.marker_ids):
            lines.append(f'{t},{marker},' + ','.join(f'{v:.9f}' for v in tracks.xyz[k, m]))
    path.write_text('\n'.join(lines) + '\n')
    return path


def test_read_and_resample_keep_linear_motion(tmp_path: Path) -> None:
    """Reading the CSV and resampling 100 Hz -> 50 FPS reproduces a linear motion exactly."""
    tracks = lifted_grid(np.arange(0, 0.31, 0.01))
    got = ft.resample(ft.read_marker_csv(write_csv(tmp_path / 'm.csv', tracks)), 50.0)
    assert len(got.times) == 16
    np.testing.assert_allclose(got.times, np.arange(16) / 50.0, atol=1e-12)
    np.testing.assert_allclose(got.xyz, lifted_grid(got.times).xyz, atol=1e-8)


def test_bad_csv_names_file(tmp_path: Path) -> None:
    """A CSV with another header is refused with the file name in the message."""
    path = tmp_path / 'bad.csv'
    path.write_text('a,b\n1,2\n')
    with pytest.raises(TwinError, match=r'bad\.csv'):
        ft.read_marker_csv(path)


def test_clean_clicks_triangulate_to_truth() -> None:
    """Noise-free projections through the true rig triangulate back to the field positions."""
    tracks = lifted_grid(np.linspace(0, 0.5, 6))
    field = ft.shift(tracks, ft.grid_origin(tracks))
    rig = paper_rig()
    uv = ft.project_tracks(rig.cameras, field.xyz)
    assert ft.outside_image(rig.cameras, uv) == 0
    side, front = rig.cameras  # OpenCV's linear triangulation from the undistorted pixels
    norm = [c.undistort_points(uv[:, k].reshape(-1, 2), normalized=True) for k, c in
            enumerate((side, front))]
    proj = [np.hstack([c.R, c.t.reshape(3, 1)]) for c in (side, front)]
    xyzw = cv2.triangulatePoints(proj[0], proj[1], norm[0].T, norm[1].T)
    np.testing.assert_allclose((xyzw[:3] / xyzw[3]).T, field.xyz.reshape(-1, 3), atol=1e-6)


def test_click_noise_has_the_papers_spread() -> None:
    """Clicking noise has zero mean and the paper's 2.36 / 2.75 px standard deviations."""
    uv = np.zeros((20000, 2))
    noisy = ft.click_noise(uv, (2.36, 2.75), np.random.default_rng(0))
    np.testing.assert_allclose(noisy.std(axis=0), [2.36, 2.75], rtol=0.03)
    np.testing.assert_allclose(noisy.mean(axis=0), [0.0, 0.0], atol=0.06)


def test_bag_holds_clicked_points_and_previews(tmp_path: Path) -> None:
    """The bag has PixelPoints (clicked) and JPEG previews with dark markers where projected."""
    tracks = lifted_grid(np.arange(3) / 50.0)
    field = ft.shift(tracks, ft.grid_origin(tracks))
    rig, config = paper_rig(), ft.FieldTwinConfig(seed=1)
    clicked = ft.click_noise(ft.project_tracks(rig.cameras, field.xyz), config.sigma_px,
                             np.random.default_rng(1))
    store = make_typestore()
    bag = write_bag(tmp_path / 'field', ft.field_messages(field, rig.cameras, clicked, config,
                                                          store.types), typestore=store)
    points_topic = topics.camera_topic(topics.PIXEL_POINTS, 'cam_front')
    image_topic = topics.camera_topic(topics.IMAGE_COMPRESSED, 'cam_front')
    with open_bag(bag) as reader:
        points = [reader.deserialize(r) for r in reader.messages([points_topic])]
        images = [reader.deserialize(r) for r in reader.messages([image_topic])]
    assert len(points) == len(images) == 3
    assert list(points[1].marker_ids) == list(range(1, 16))
    assert set(points[1].source) == {1}  # PixelPoints.SOURCE_CLICKED
    np.testing.assert_allclose(points[1].u, clicked[1, 1, :, 0])
    img = cv2.imdecode(np.asarray(images[0].data, np.uint8), cv2.IMREAD_GRAYSCALE)
    assert img.shape == (540, 960)
    u, v = rig.front.project(field.xyz[0, 7:8])[0] * config.image_scale
    assert img[round(v), round(u)] < 80, 'no dark marker at the projected position'
    assert np.median(img) > 120, 'background is not sand-coloured'
