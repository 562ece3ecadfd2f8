"""OpenCV's version is checked before calibration starts: one clear line on 4.6 (Debian 12's)."""

from __future__ import annotations

import cv2

from dempath_calib.opencv_check import opencv_problem, require_charuco_opencv


def test_debian_opencv_4_6_is_refused_in_one_line() -> None:
    """4.6 (no CharucoDetector) and a 4.7 build without aruco name the need and the fix."""
    for version, has in (('4.6.0', False), ('4.7.0', False), ('4.5.4-dev', False)):
        problem = opencv_problem(version, has)
        assert problem is not None and '\n' not in problem
        assert problem.startswith(f'OpenCV {version}: ChArUco calibration needs OpenCV >= 4.7')
        assert 'pip install "opencv-contrib-python-headless>=4.7"' in problem


def test_installed_opencv_passes() -> None:
    """The pinned OpenCV (4.12) has the detector; the check lets it through."""
    assert opencv_problem('4.12.0', True) is None
    assert opencv_problem('5.0.0', True) is None
    assert hasattr(cv2.aruco, 'CharucoDetector')
    require_charuco_opencv()
