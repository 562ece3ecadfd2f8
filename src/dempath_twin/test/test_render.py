"""The twin renderer is geometrically exact and the detector is unbiased on it."""

from __future__ import annotations

import numpy as np

from dempath_calib.board import PAPER_BOARD, BoardKind, CornerDetector
from dempath_twin.board.recording import calibration_poses, surface_pose
from dempath_twin.board.renderer import BoardRenderer, FrameConditions, board_texture
from dempath_twin.rig import paper_rig

# Tolerances: mean detection bias below 0.05 px, RMS below 0.3 px on rendered views.
MAX_BIAS_PX = 0.05
MAX_RMS_PX = 0.3


def test_texture_corners_are_where_the_map_says() -> None:
    """Chessboard corners of the texture sit where the texture->board map puts them."""
    import cv2
    texture, a = board_texture(PAPER_BOARD)
    found, corners = cv2.findChessboardCornersSB((texture * 255).astype(np.uint8), (6, 4),
                                                 flags=cv2.CALIB_CB_ACCURACY)
    assert found
    obj = PAPER_BOARD.object_points()[:, :2]
    tex = np.linalg.solve(a, np.column_stack([obj, np.ones(len(obj))]).T).T[:, :2]
    got = corners.reshape(-1, 2)
    # findChessboardCornersSB may start from either end of the grid
    err = min(np.abs(got - tex).max(), np.abs(got[::-1] - tex).max())
    assert err < 0.05


def test_rendered_corners_match_projection() -> None:
    """Detected corners of rendered views agree with camera.project of the true corners."""
    rig = paper_rig()
    rng = np.random.default_rng(3)
    poses = [surface_pose(PAPER_BOARD), *calibration_poses(8, seed=3)[3:]]
    det = CornerDetector(PAPER_BOARD)
    errors = []
    for cam in rig.cameras:
        renderer = BoardRenderer(cam, PAPER_BOARD, seed=1)
        for pose in poses[:5]:
            img = renderer.render(pose.rot, pose.t, FrameConditions(), rng)
            truth = cam.project(PAPER_BOARD.object_points() @ pose.rot.T + pose.t)
            errors.append(det.detect(img) - truth)
    e = np.concatenate(errors)
    e = e[~np.isnan(e[:, 0])]
    assert len(e) > 150, f'only {len(e)} corners found'
    assert np.all(np.abs(e.mean(0)) < MAX_BIAS_PX), e.mean(0)
    assert np.sqrt(np.mean(np.sum(e ** 2, 1))) < MAX_RMS_PX


def test_chessboard_detection() -> None:
    """A plain chessboard target renders and is found with all corners near the truth."""
    from dataclasses import replace
    board = replace(PAPER_BOARD, kind=BoardKind.CHESSBOARD)
    cam = paper_rig().side
    pose = calibration_poses(6, seed=2)[4]
    img = BoardRenderer(cam, board).render(pose.rot, pose.t, FrameConditions(),
                                           np.random.default_rng(0))
    got = CornerDetector(board).detect(img)
    truth = cam.project(board.object_points() @ pose.rot.T + pose.t)
    assert not np.isnan(got).any()
    err = min(np.abs(got - truth).max(), np.abs(got[::-1] - truth).max())
    assert err < 0.5
