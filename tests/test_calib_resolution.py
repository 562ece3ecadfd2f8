"""A calibration and a recording of other resolutions: scaled when the aspect ratio is the same
(said), refused with one line naming both sizes otherwise (every 3D point used to be rejected in
silence and the demo ended with "no scores after the model run", blaming the scene)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath_bringup.nodes.graph import GraphSpec, fitted_calibration
from dempath_calib.camera import StereoCalibration
from dempath_calib.errors import CalibrationError
from dempath_calib.resize import fit_to_images, scale_camera
from dempath_twin.rig import paper_rig

ROOT = Path(__file__).resolve().parents[1]
RENDER = ROOT / 'bags' / 'field_render_reduced_1ms'  # 1920 x 1080 px


def test_scaled_camera_projects_the_scaled_pixels() -> None:
    """Half the size: every world point lands on the half-size pixel of the full-size one."""
    cam = paper_rig().side
    half = scale_camera(cam, cam.width // 2, cam.height // 2)
    rng = np.random.default_rng(1)
    world = rng.uniform([-0.2, -0.15, 0.1], [0.2, 0.05, 0.5], (50, 3))
    full_uv, half_uv = cam.project(world), half.project(world)
    np.testing.assert_allclose((full_uv + 0.5) * 0.5 - 0.5, half_uv, atol=1e-9)


def rig_at(width: int, height: int) -> StereoCalibration:
    """The twin rig's calibration as if made at ``width`` x ``height`` px (same geometry)."""
    rig = paper_rig()
    s = width / rig.side.width
    cams = [scale_camera(c, width, height) if abs(c.width * height / c.height - width) < 1
            else type(c)(c.name, width, height, c.K * np.array([[s], [s], [1.0]]), c.dist,
                         c.R, c.t)
            for c in rig.cameras]
    return StereoCalibration(cams[0], cams[1], {})


def test_other_aspect_is_refused_with_both_sizes() -> None:
    """A 4:3 calibration for 16:9 images: one error naming the recording, camera and sizes."""
    with pytest.raises(CalibrationError) as err:
        fit_to_images(rig_at(1600, 1200), {'cam_side': (1920, 1080)}, 'field.bag')
    text = str(err.value)
    assert text.startswith('field.bag: cam_side images are 1920x1080 px') and '1600x1200' in text
    assert '\n' not in text


def test_demo_scales_a_same_aspect_calibration(tmp_path: Path) -> None:
    """The demo's graph, given a 3840x2160 calibration for the 1920x1080 render, runs with a
    scaled copy saved beside its output and says so."""
    calib = rig_at(3840, 2160).save(tmp_path / 'calib.yaml')
    spec = GraphSpec(RENDER, calib, 'tiny', tmp_path / 'run_bag', detect=True)
    notes: list[str] = []
    fitted = fitted_calibration(spec, notes.append)
    assert fitted.calibration != calib and fitted.calibration.is_file()
    used = StereoCalibration.load(fitted.calibration)
    assert [(c.width, c.height) for c in used.cameras] == [(1920, 1080)] * 2
    np.testing.assert_allclose(used.side.K, paper_rig().side.K, atol=1e-9)
    assert len(notes) == 2 and 'scaled by 0.5' in notes[0]


def test_demo_refuses_another_aspect(tmp_path: Path) -> None:
    """A 1600x1200 calibration for the 1920x1080 render: refused before any node starts."""
    calib = rig_at(1600, 1200).save(tmp_path / 'calib.yaml')
    spec = GraphSpec(RENDER, calib, 'tiny', tmp_path / 'run_bag', detect=True)
    with pytest.raises(CalibrationError, match='1920x1080 px but the calibration is for '
                                               '1600x1200 px'):
        fitted_calibration(spec, lambda text: None)
    assert not (tmp_path / 'run_bag').exists()
