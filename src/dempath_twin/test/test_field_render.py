"""Rendered field recordings: geometry, occlusion by grains, the bag with its truth, and which
markers a rig's cameras can see (coverage without images)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from dempath.bagio import open_bag
from dempath_twin.render.bag import write_field_recording
from dempath_twin.render.bed_source import BedRecord
from dempath_twin.render.camera_frame import FieldCamera, Look, scaled_camera
from dempath_twin.render.coverage import rig_coverage, truth_coverage
from dempath_twin.render.recording import (
    FieldScene,
    RecordingConfig,
    field_frames,
    light_change,
    lighting,
    render_frame,
)
from dempath_twin.rig import carriage_rig, paper_rig

R = 0.006  # grain radius [m]


def small_bed(n_times: int = 4) -> BedRecord:
    """A 12 mm grain layer (Y = 0) with 3 markers; a grain lies over marker 3 towards the side
    camera (between them).

    The bed slides along +Z at 0.2 m/s so that frames differ.
    """
    xs, zs = np.meshgrid(np.arange(-0.06, 0.061, 2 * R), np.arange(-0.09, 0.091, 2 * R))
    layer = np.column_stack([xs.ravel(), np.zeros(xs.size), zs.ravel()])
    marker_index = np.array([np.argmin(np.linalg.norm(layer - p, axis=1))
                             for p in ([-0.036, 0, 0.0], [0.0, 0, 0.0], [0.036, 0, 0.0])])
    clay = layer[marker_index[2]] + [0.0, R - 0.004, 0.0]  # clay sphere top flush with grain
    sight = paper_rig().side.center - clay
    cover = clay + 0.014 * sight / np.linalg.norm(sight)
    pos0 = np.vstack([layer, cover[None]])
    times = np.arange(n_times) * 0.01
    pos = np.stack([pos0 + np.array([0.0, 0.0, 0.2 * t]) for t in times]).astype(np.float32)
    grid = pos0[marker_index].copy()
    return BedRecord(times, pos, np.full(len(pos0), R), np.arange(len(pos0)),
                     np.array([1, 2, 3], np.int32), marker_index.astype(np.int64), times,
                     np.tile([0.0, 0.3, 0.5], (n_times, 1)), np.zeros((0, 3, 3)),
                     {'run_id': 'synthetic', 'grid_points': grid.tolist()})


@pytest.fixture(scope='module')
def frame():
    """One rendered side-camera frame of the small bed at a quarter of 1920 x 1080."""
    cam = FieldCamera(scaled_camera(paper_rig().side, 0.5), Look(blur_subframes=1))
    rng = np.random.default_rng(0)
    scene = FieldScene(small_bed(), cam.look, rng)
    light = lighting(np.array([0.0, 0.02]), rng)[0]
    return cam, scene, render_frame(cam, scene, 0.01, light, rng)


def test_markers_project_where_the_camera_says(frame) -> None:
    """Truth pixels are camera.project of the clay spheres' centres; they look blue there."""
    cam, scene, (image, truth) = frame
    assert np.allclose(truth.uv, cam.camera.project(scene.markers(0.01)))
    for k in (0, 1):
        u, v = np.rint(truth.uv[k]).astype(int)
        b, _, r = image[v, u].astype(int)
        assert b > r + 20, (k, image[v, u])


def test_occlusion_comes_from_the_grains(frame) -> None:
    """Markers 1-2 are mostly visible; marker 3, under a grain, is hidden by it."""
    _, _, (_, truth) = frame
    assert truth.visible[0] > 0.6 and truth.visible[1] > 0.6, truth.visible
    assert truth.visible[2] < 0.2, truth.visible


def test_recording_bag_and_truth(tmp_path) -> None:
    """Bag with JPEG + CameraInfo per camera, front stamps 3 ms later, truth beside the bag."""
    config = RecordingConfig(scale=0.25, calib_views=1, max_frames=2,
                             look=Look(blur_subframes=2, supersample=1))
    bag, truth = write_field_recording(small_bed(), paper_rig(), tmp_path / 'rec', config)
    with open_bag(bag) as reader:
        assert set(reader.topics) == {f'/{c}/{t}' for c in ('cam_side', 'cam_front')
                                      for t in ('image_raw/compressed', 'camera_info')}
        assert reader.topics['/cam_side/image_raw/compressed'].msgcount == 3
    data = json.loads((tmp_path / 'rec.truth.json').read_text())
    side = [f['stamp_ns'] for f in data['frames'] if f['camera'] == 'cam_side']
    front = [f['stamp_ns'] for f in data['frames'] if f['camera'] == 'cam_front']
    assert np.allclose(np.subtract(front, side), 3_000_000)
    assert data['calibration_segment']['views'] == 1 and len(data['marker_grid_m']) == 3
    assert len(truth) == 4


def test_tool_triangles_are_depth_tested_and_cast_shadows() -> None:
    """A steel triangle in front of a grain hides it; the triangle shadows what lies under it."""
    from dempath_twin.render.camera_frame import Scene3D, ShadowMap

    cam = FieldCamera(scaled_camera(paper_rig().side, 0.25), Look(supersample=1))
    tri = np.array([[[0.05, -0.05, -0.05], [0.05, -0.05, 0.05], [0.05, 0.08, 0.0]]])
    grain = np.array([[0.0, 0.0, 0.0]])
    scene = Scene3D(grain, np.array([R]), np.ones((1, 3), np.float32), np.zeros(1, np.float32),
                    tri)
    _, ibuf, _ = cam.buffers(scene)
    uv = cam.camera.project(np.vstack([grain, tri[0].mean(0)[None]]))
    ox, oy = cam.origin
    for (u, v), want in zip(uv, (1, 1), strict=True):  # index 1 = the tool (1 sphere)
        assert ibuf[round(v - oy), round(u - ox)] == want
    shadow = ShadowMap(scene, (1.0, 0.0, 0.0))  # light from +X: the grain is behind the tool
    assert shadow.lit(grain + np.array([[R, 0.0, 0.0]]))[0] == 0.0  # in the shadow
    assert shadow.lit(np.array([[0.0, 0.0, 0.2]]))[0] == 1.0


def test_look_sets_light_sand_and_marker_colours() -> None:
    """The renderer's look options (``twin render --light --sand-bgr --marker-bgr``): half the
    light halves the sand's grey levels; another sand and marker albedo change their pixels
    (the markers stay bluer than the sand within the detector's documented range)."""
    rig_cam = scaled_camera(paper_rig().side, 0.5)

    def render(look: Look) -> tuple[np.ndarray, np.ndarray]:
        cam = FieldCamera(rig_cam, look)
        rng = np.random.default_rng(0)
        scene = FieldScene(small_bed(), look, rng)
        light = lighting(np.array([0.0, 0.02]), rng)[0]
        image, truth = render_frame(cam, scene, 0.01, light, rng)
        return image.astype(float), truth.uv

    base = Look(blur_subframes=1, noise_dn=0.0)
    image, uv = render(base)
    dim, _ = render(Look(blur_subframes=1, noise_dn=0.0, light=0.5))
    mid = np.rint(0.5 * (uv[0] + uv[1])).astype(int)  # grains between markers 1 and 2
    sand = (slice(mid[1] - 3, mid[1] + 4), slice(mid[0] - 3, mid[0] + 4))
    ratio = dim[sand].mean() / image[sand].mean()
    assert 0.45 < ratio < 0.55, ratio
    red, _ = render(Look(blur_subframes=1, noise_dn=0.0, sand_bgr=(0.30, 0.50, 0.75),
                         marker_bgr=(0.55, 0.25, 0.15)))
    b, g, r = (red[sand][..., c].mean() / image[sand][..., c].mean() for c in range(3))
    assert b < 0.8 and r > 1.0, (b, g, r)
    u, v = np.rint(uv[0]).astype(int)
    assert red[v, u, 0] < image[v, u, 0] and red[v, u, 0] > red[v, u, 2] + 20


def test_light_changes_within_a_pass() -> None:
    """``twin render --flicker --cloud``: each frame's light level within 1 +- flicker, not the
    same from frame to frame, repeatable by seed; a cloud dims the middle of the pass to its
    level and leaves the ends; neither set: every level 1 (renders as before)."""
    times = np.arange(21) / 50.0
    assert np.array_equal(light_change(times, 0.0, 1.0, 5), np.ones(21))
    flick = light_change(times, 0.3, 1.0, 5)
    assert np.all(np.abs(flick - 1) <= 0.3) and np.ptp(flick) > 0.3, flick
    assert np.array_equal(flick, light_change(times, 0.3, 1.0, 5))
    assert not np.array_equal(flick, light_change(times, 0.3, 1.0, 6))
    cloud = light_change(times, 0.0, 0.4, 5)
    assert cloud[0] == pytest.approx(1.0) and cloud[-1] == pytest.approx(1.0)
    assert cloud[10] == pytest.approx(0.4) and cloud.min() == pytest.approx(0.4)
    rng = np.random.default_rng(0)
    plain = lighting(times, rng)
    rng = np.random.default_rng(0)
    dimmed = lighting(times, rng, cloud)
    assert dimmed[0] == plain[0] and dimmed[10].gain == pytest.approx(0.4 * plain[10].gain)
    with pytest.raises(ValueError, match='flicker'):
        Look(flicker=1.5)
    with pytest.raises(ValueError, match='cloud'):
        Look(cloud=0.0)


def test_a_cloud_darkens_the_recordings_middle_frames() -> None:
    """A recording with ``Look.cloud`` 0.4: its middle frame's sand is darker than the same
    recording's without the cloud by about that factor, its first frame as bright."""
    def means(look: Look) -> list[float]:
        config = RecordingConfig(scale=0.25, calib_views=1, max_frames=5, look=look)
        frames = field_frames(small_bed(12), paper_rig(), config, 0.0, [])
        return [float(image.mean()) for cam, image, _ in frames if cam == 'cam_side']

    look = Look(blur_subframes=1, supersample=1, noise_dn=0.0)
    clear, cloudy = means(look), means(replace(look, cloud=0.4))
    assert len(clear) == 5 and cloudy[0] == pytest.approx(clear[0], rel=0.02)
    assert 0.3 < cloudy[2] / clear[2] < 0.5, (cloudy, clear)


def test_coverage_without_images_is_the_renders_truth(tmp_path) -> None:
    """rig_coverage gives the shares the rendered recording's truth gives, frame for frame."""
    config = RecordingConfig(scale=0.25, calib_views=0, max_frames=3,
                             look=Look(blur_subframes=2, supersample=1))
    write_field_recording(small_bed(), paper_rig(), tmp_path / 'rec', config)
    truth = truth_coverage(json.loads((tmp_path / 'rec.truth.json').read_text()))
    quick = rig_coverage(small_bed(), paper_rig(), config)
    assert quick.frames == truth.frames == 2
    assert np.allclose(quick.both, truth.both)
    for cam in ('cam_side', 'cam_front'):
        assert np.allclose(quick.per_camera[cam], truth.per_camera[cam])


def test_the_carriage_rig_sees_over_the_grain_that_hides_a_marker() -> None:
    """Marker 3 lies under a grain on the fixed side camera's line of sight (30 deg above the
    surface): that camera never sees it; from the carriage frame, looking steeply down, both
    cameras see all three markers."""
    config = RecordingConfig(scale=0.5, calib_views=0, max_frames=3,
                             look=Look(blur_subframes=1, supersample=1))
    fixed = rig_coverage(small_bed(), paper_rig(), config)
    assert fixed.per_camera['cam_side'][2] == 0.0 and 3 not in fixed.reconstructed
    carriage = rig_coverage(small_bed(), carriage_rig(), config)
    assert carriage.reconstructed == [1, 2, 3], carriage.to_json()
