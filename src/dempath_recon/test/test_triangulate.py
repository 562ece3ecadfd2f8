"""Classical triangulation against the twin's known geometry."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_recon.errors import NotFittedError, PixelInputError, ReconstructionError
from dempath_recon.methods.resection import resect_stereo
from dempath_recon.methods.triangulate import (
    DLTTriangulator,
    project_points,
    project_with_jacobian,
    solve3,
    split_views,
    triangulate_points,
)
from dempath_twin.rig import sample_working_volume


def test_projection_matches_opencv(rig) -> None:
    """The numpy projection equals cv2.projectPoints (CameraModel.project) to 1e-9 px."""
    xyz = sample_working_volume(500, np.random.default_rng(0))
    for cam in rig.cameras:
        assert np.abs(project_points(cam, xyz) - cam.project(xyz)).max() < 1e-9


def test_analytic_jacobian_matches_differences(rig) -> None:
    """d uv / d xyz from the chain rule equals central differences within 1e-4 relative."""
    xyz = sample_working_volume(200, np.random.default_rng(1))
    for cam in rig.cameras:
        _, jac = project_with_jacobian(cam, xyz)
        for k in range(3):
            d = np.zeros(3)
            d[k] = 1e-7
            num = (project_points(cam, xyz + d) - project_points(cam, xyz - d)) / 2e-7
            assert np.abs(num - jac[:, :, k]).max() < 1e-4 * np.abs(jac).max()


def test_solve3_matches_linalg() -> None:
    """The adjugate 3x3 solver equals numpy.linalg.solve."""
    rng = np.random.default_rng(2)
    a = rng.normal(size=(100, 3, 3)) + 3 * np.eye(3)
    b = rng.normal(size=(100, 3))
    assert np.allclose(solve3(a, b), np.linalg.solve(a, b[:, :, None])[:, :, 0], atol=1e-12)


@pytest.mark.parametrize('refine', [False, True])
def test_noise_free_points_are_recovered(rig, clean_points, refine: bool) -> None:
    """Exact pixels give the exact 3D corners (1e-9 m) and zero reprojection error."""
    res = triangulate_points(rig.cameras, split_views(clean_points.pixels), refine=refine)
    assert np.abs(res.xyz - clean_points.xyz).max() < 1e-9
    assert np.nanmax(res.reprojection_error) < 1e-6
    assert (res.n_views == 2).all()


def test_missing_view_gives_nan(rig, clean_points) -> None:
    """A NaN in either view makes that point NaN; the other points are unaffected."""
    pixels = clean_points.pixels[:10].copy()
    pixels[3, 0] = np.nan
    pixels[7, 3] = np.nan
    res = DLTTriangulator().fit(calibration=rig).triangulate(pixels)
    assert np.isnan(res.xyz[[3, 7]]).all()
    assert list(res.n_views[[3, 7]]) == [1, 1]
    keep = np.setdiff1d(np.arange(10), [3, 7])
    assert np.abs(res.xyz[keep] - clean_points.xyz[keep]).max() < 1e-9


def test_noisy_corners_meet_the_accuracy_target(rig, points) -> None:
    """With 0.2 px corner noise: mean 3D error < 0.5 mm and max < 3 mm, refined <= linear."""
    truth = points.xyz
    errs = {}
    for refine in (False, True):
        est = DLTTriangulator(refine=refine).fit(calibration=rig).predict(points.pixels)
        errs[refine] = np.linalg.norm(est - truth, axis=1)
    assert errs[True].mean() < 0.5e-3 and errs[True].max() < 3e-3
    assert errs[True].mean() <= errs[False].mean() * 1.001


def test_resection_recovers_the_cameras(rig, points) -> None:
    """Cameras resected from the point set: fx, fy within 2 px, centres within 2 mm."""
    cams = resect_stereo(points.pixels, points.xyz)
    for est, true in zip(cams, rig.cameras, strict=True):
        assert np.abs(np.diag(est.K)[:2] - np.diag(true.K)[:2]).max() < 2.0
        assert np.linalg.norm(est.center - true.center) < 2e-3


def test_resected_triangulator_is_as_good_as_truth(rig, points) -> None:
    """Fitted on 3,000 samples without a calibration: held-out mean error < 0.5 mm."""
    tri = DLTTriangulator().fit(points.pixels[:3000], points.xyz[:3000])
    err = np.linalg.norm(tri.predict(points.pixels[3000:]) - points.xyz[3000:], axis=1)
    assert err.mean() < 0.5e-3


def test_bad_inputs_raise_clear_errors(rig) -> None:
    """Unfitted, wrong shapes and no calibration each raise the package's error."""
    with pytest.raises(NotFittedError, match='not fitted'):
        DLTTriangulator().predict(np.zeros((1, 4)))
    with pytest.raises(PixelInputError, match=r'\(n, 4\)'):
        DLTTriangulator().fit(calibration=rig).predict(np.zeros((3, 3)))
    with pytest.raises(ReconstructionError, match='give a calibration'):
        DLTTriangulator().fit()
