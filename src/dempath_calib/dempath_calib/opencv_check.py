"""The OpenCV that ChArUco calibration needs, checked before any work starts.

The ChArUco detection uses ``cv2.aruco.CharucoDetector``, new in OpenCV 4.7 (the older
``cv2.aruco.interpolateCornersCharuco`` API was removed from the contrib module). ``make setup``
installs ``opencv-contrib-python-headless`` 4.12; an apt ROS install on Debian 12 brings
``python3-opencv`` 4.6, which lacks it: calibration then stops with one line saying so and how to
get a newer OpenCV (docs/ros.md). Everything else in dempath runs on 4.6.
"""

from __future__ import annotations

import cv2

from dempath_calib.errors import CalibrationError

MIN_VERSION = (4, 7)
FIX = 'pip install "opencv-contrib-python-headless>=4.7" (docs/ros.md, "OpenCV")'


def opencv_problem(version: str, has_charuco_detector: bool) -> str | None:
    """What stops ChArUco calibration with OpenCV ``version``, or None when nothing does.

    Args:
        version: ``cv2.__version__``, e.g. ``'4.6.0'``.
        has_charuco_detector: whether ``cv2.aruco.CharucoDetector`` exists.
    """
    try:
        major_minor = tuple(int(part) for part in version.split('.')[:2])
    except ValueError:
        major_minor = (0, 0)
    if major_minor < MIN_VERSION or not has_charuco_detector:
        need = '.'.join(map(str, MIN_VERSION))
        return (f'OpenCV {version}: ChArUco calibration needs OpenCV >= {need} with '
                f'cv2.aruco.CharucoDetector; {FIX}')
    return None


def require_charuco_opencv() -> None:
    """Raise :class:`CalibrationError` (one line) when this OpenCV cannot detect ChArUco boards."""
    aruco = getattr(cv2, 'aruco', None)
    problem = opencv_problem(cv2.__version__, hasattr(aruco, 'CharucoDetector'))
    if problem is not None:
        raise CalibrationError(problem)
