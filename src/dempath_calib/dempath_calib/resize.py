"""A calibration fitted to the size of the images it is used on.

A calibration made at 1920x1080 px and a recording at 960x540 px disagree about every pixel: the
triangulated points land nowhere and are all rejected. When both have the same aspect ratio the
recording is a uniformly scaled sensor and the calibration is scaled with it (focal lengths and
principal point by the same factor, about pixel centres: ``c' = (c + 0.5) s - 0.5``; distortion
coefficients act on normalised coordinates and stay); otherwise the pair is refused with one
line naming both sizes.
"""

from __future__ import annotations

from dataclasses import replace

from dempath_calib.camera import CameraModel, StereoCalibration
from dempath_calib.errors import CalibrationError

ASPECT_TOLERANCE = 2e-3  # relative difference of width/height taken as the same aspect


def scale_camera(camera: CameraModel, width: int, height: int) -> CameraModel:
    """``camera`` for images of ``width`` x ``height`` px of the same aspect ratio."""
    s = width / camera.width
    k = camera.K.copy()
    k[0, 0], k[1, 1] = k[0, 0] * s, k[1, 1] * s
    k[0, 2], k[1, 2] = (k[0, 2] + 0.5) * s - 0.5, (k[1, 2] + 0.5) * s - 0.5
    return replace(camera, width=int(width), height=int(height), K=k)


def fit_to_images(calib: StereoCalibration, sizes: dict[str, tuple[int, int]], source: str,
                  ) -> tuple[StereoCalibration, list[str]]:
    """The calibration for images of ``sizes`` (``{camera name: (width, height)}``).

    Args:
        calib: The stereo calibration.
        sizes: The recording's image size per camera name; cameras not listed are kept.
        source: The recording, for messages.

    Returns:
        (the calibration, unchanged or scaled; one note per scaled camera).

    Raises:
        CalibrationError: A camera's images have another aspect ratio than its calibration.
    """
    cameras, notes = [], []
    for cam in calib.cameras:
        width, height = sizes.get(cam.name, (cam.width, cam.height))
        if (width, height) == (cam.width, cam.height):
            cameras.append(cam)
            continue
        if abs((width / height) / (cam.width / cam.height) - 1.0) > ASPECT_TOLERANCE:
            msg = (f'{source}: {cam.name} images are {width}x{height} px but the calibration '
                   f'is for {cam.width}x{cam.height} px (another aspect ratio); calibrate at '
                   "the recording's resolution")
            raise CalibrationError(msg)
        cameras.append(scale_camera(cam, width, height))
        notes.append(f'{cam.name}: calibration {cam.width}x{cam.height} px scaled by '
                     f"{width / cam.width:.4g} to the recording's {width}x{height} px")
    if not notes:
        return calib, []
    info = {**calib.info, 'scaled_to_recording': notes}
    return StereoCalibration(cameras[0], cameras[1], info), notes


__all__ = ['ASPECT_TOLERANCE', 'fit_to_images', 'scale_camera']
