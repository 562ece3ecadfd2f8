"""The streaming core of the node: rejection reasons, accuracy, uncertainty, config checks."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_recon.errors import ModelFileError, ReconstructionError
from dempath_recon.pairing import FRONT, SIDE, PixelFrame
from dempath_recon.stream import (
    REASON_FAILED,
    REASON_NAN,
    REASON_OUTSIDE,
    MarkerStream,
    StreamConfig,
    reconstruct_sequence,
    reject_pixels,
)
from dempath_twin.rig import sample_working_volume


def marker_frames(rig, n_frames: int, seed: int) -> tuple[list[PixelFrame], np.ndarray]:
    """Frames of 5 markers seen by both cameras at 50 fps; truth (n_frames, 5, 3) m."""
    rng = np.random.default_rng(seed)
    truth = sample_working_volume(n_frames * 5, rng).reshape(n_frames, 5, 3)
    out = []
    for k in range(n_frames):
        for cam_index, cam in zip((SIDE, FRONT), rig.cameras, strict=True):
            out.append(PixelFrame(cam_index, 0.02 * k + 0.001 * cam_index,
                                  np.arange(1, 6), cam.project(truth[k])))
    return out, truth


def test_reject_pixels_names_each_reason() -> None:
    """NaN, left of the side image and below the front image are told apart."""
    pixels = np.array([[10, 10, 10, 10], [np.nan, 5, 5, 5], [-1, 5, 5, 5], [5, 5, 5, 1081.0]])
    reasons = reject_pixels(pixels, [(1920, 1080), (1920, 1080)])
    assert list(reasons) == ['', REASON_NAN, REASON_OUTSIDE[0], REASON_OUTSIDE[1]]


def test_stream_reconstructs_markers_with_sigma(rig, tmp_path) -> None:
    """From a calibration file: exact markers to 1e-9 m, sigma > 0, zero reprojection error."""
    cfg = StreamConfig(method='dlt_refined', calibration_file=str(rig.save(tmp_path / 'c.yaml')),
                       slop_s=0.005)
    frames, truth = marker_frames(rig, 6, seed=0)
    out = reconstruct_sequence(MarkerStream.from_config(cfg), frames)
    assert len(out) == 6
    for k, f in enumerate(out):
        assert list(f.ids) == [1, 2, 3, 4, 5]
        assert np.abs(f.xyz - truth[k]).max() < 1e-9
        assert (f.sigma > 0).all() and (f.sigma < 0.01).all()
        assert np.nanmax(f.reprojection_error) < 1e-6


def test_stream_rejects_bad_points_with_reasons(rig, tmp_path) -> None:
    """A NaN point, an outside point and a marker behind the camera are counted by cause."""
    cfg = StreamConfig(calibration_file=str(rig.save(tmp_path / 'c.yaml')))
    stream = MarkerStream.from_config(cfg)
    frames, truth = marker_frames(rig, 1, seed=1)
    side, front = frames
    uv = side.uv.copy()
    uv[0] = np.nan
    uv[1] = (2500.0, 300.0)
    out = stream.update(PixelFrame(SIDE, side.stamp_s, side.ids, uv)) + stream.update(front)
    (f,) = out
    assert list(f.ids) == [3, 4, 5]
    assert np.abs(f.xyz - truth[0, 2:]).max() < 1e-9
    assert f.rejected == {REASON_NAN: 1, REASON_OUTSIDE[0]: 1}
    assert stream.rejected[REASON_NAN] == 1
    assert REASON_FAILED not in f.rejected


def test_config_and_files_are_checked(tmp_path) -> None:
    """Unknown method and negative slop are ValueErrors; missing/corrupt files one clear error."""
    with pytest.raises(ValueError, match='method'):
        StreamConfig(method='magic')
    with pytest.raises(ValueError, match='slop_s'):
        StreamConfig(slop_s=-0.1)
    with pytest.raises(ReconstructionError, match='calibration_file'):
        MarkerStream.from_config(StreamConfig(method='dlt'))
    with pytest.raises(ModelFileError, match='not found'):
        MarkerStream.from_config(StreamConfig(calibration_file=str(tmp_path / 'missing.yaml')))
    bad = tmp_path / 'bad.yaml'
    bad.write_text('side: [1, 2\n')
    with pytest.raises(ModelFileError, match=r'bad\.yaml'):
        MarkerStream.from_config(StreamConfig(calibration_file=str(bad)))
    with pytest.raises(ModelFileError, match='not found'):
        MarkerStream.from_config(StreamConfig(method='mlp', model_file=str(tmp_path / 'm.pt')))


def test_stream_with_a_learned_model_file(rig, points, tmp_path) -> None:
    """dlt_residual from its model file: markers within 0.1 mm, sigma from the generic Jacobian."""
    from dempath_recon.methods.residual import ResidualReconstructor

    model = ResidualReconstructor(epochs=2, random_state=0, device='cpu').fit(
        points.pixels[:1000], points.xyz[:1000], calibration=rig).save(tmp_path / 'res.pt')
    cfg = StreamConfig(method='dlt_residual', model_file=str(model),
                       calibration_file=str(rig.save(tmp_path / 'c.yaml')))
    frames, truth = marker_frames(rig, 3, seed=5)
    out = reconstruct_sequence(MarkerStream.from_config(cfg), frames)
    assert len(out) == 3
    for k, f in enumerate(out):
        assert np.abs(f.xyz - truth[k]).max() < 1e-4
        assert (f.sigma > 0).all() and (f.sigma < 0.01).all()
        assert np.nanmax(f.reprojection_error) < 0.5
