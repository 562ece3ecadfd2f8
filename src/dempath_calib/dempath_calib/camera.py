"""Pinhole camera models with OpenCV's radial-tangential distortion, and the two-camera rig.

Conventions: pixel coordinates (u, v) in px with the origin at the centre of the top-left pixel
(OpenCV); camera frame x right, y down, z forward; ``R`` and ``t`` map world points into the
camera frame, ``x_cam = R @ X_world + t`` (metres). The world frame is the paper's: X lateral,
Y vertical up, Z direction of tool travel, origin on the undisturbed sand surface.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml  # type: ignore[import-untyped]
from numpy.typing import NDArray

from dempath_calib.errors import CalibrationFileError

FloatArray = NDArray[np.float64]


def _as_matrix(value: Any, shape: tuple[int, ...], name: str) -> FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.size != int(np.prod(shape)):
        msg = f'{name}: expected {shape} values, got shape {arr.shape}'
        raise ValueError(msg)
    return arr.reshape(shape).copy()


@dataclass(frozen=True)
class CameraModel:
    """One calibrated camera: intrinsics, distortion and world->camera pose.

    Attributes:
        name: camera name, e.g. ``'cam_side'``.
        width: image width [px].
        height: image height [px].
        K: (3, 3) camera matrix [px].
        dist: (5,) distortion coefficients in OpenCV order k1, k2, p1, p2, k3.
        R: (3, 3) rotation world -> camera.
        t: (3,) translation world -> camera [m].
    """

    name: str
    width: int
    height: int
    K: FloatArray
    dist: FloatArray = field(default_factory=lambda: np.zeros(5))
    R: FloatArray = field(default_factory=lambda: np.eye(3))
    t: FloatArray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        object.__setattr__(self, 'K', _as_matrix(self.K, (3, 3), 'K'))
        object.__setattr__(self, 'dist', _as_matrix(self.dist, (5,), 'dist'))
        object.__setattr__(self, 'R', _as_matrix(self.R, (3, 3), 'R'))
        object.__setattr__(self, 't', _as_matrix(self.t, (3,), 't'))
        if self.width <= 0 or self.height <= 0:
            msg = f'width/height: must be positive, got {self.width}x{self.height}'
            raise ValueError(msg)
        if abs(np.linalg.det(self.R) - 1.0) > 1e-6:
            msg = f'R: not a rotation (det {np.linalg.det(self.R):.6f})'
            raise ValueError(msg)

    @property
    def rvec(self) -> FloatArray:
        """(3,) Rodrigues vector of ``R``."""
        return np.asarray(cv2.Rodrigues(self.R)[0], np.float64).ravel()

    @property
    def center(self) -> FloatArray:
        """(3,) camera centre in the world frame [m]."""
        return -self.R.T @ self.t

    @property
    def projection_matrix(self) -> FloatArray:
        """(3, 4) ``K [R | t]`` for undistorted pixels."""
        return self.K @ np.hstack([self.R, self.t[:, None]])

    def to_camera(self, xyz: FloatArray) -> FloatArray:
        """World points (n, 3) m -> camera-frame points (n, 3) m."""
        return np.asarray(xyz, dtype=np.float64).reshape(-1, 3) @ self.R.T + self.t

    def project(self, xyz: FloatArray) -> FloatArray:
        """Project world points with distortion.

        Args:
            xyz: (n, 3) world points [m].

        Returns:
            (n, 2) pixel coordinates [px] (points behind the camera are NaN).
        """
        pts = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        if len(pts) == 0:
            return np.zeros((0, 2))
        proj, _ = cv2.projectPoints(pts, self.rvec, self.t, self.K, self.dist)
        uv = np.asarray(proj, np.float64).reshape(-1, 2)
        uv[self.to_camera(pts)[:, 2] <= 0] = np.nan
        return uv

    def undistort_points(self, uv: FloatArray, normalized: bool = False) -> FloatArray:
        """Remove lens distortion from pixel coordinates.

        Args:
            uv: (n, 2) distorted pixel coordinates [px].
            normalized: return normalised image coordinates (x/z, y/z) instead of pixels.

        Returns:
            (n, 2) undistorted coordinates: ideal pixels [px] (same K) or normalised [-].
        """
        pts = np.asarray(uv, dtype=np.float64).reshape(-1, 1, 2)
        if len(pts) == 0:
            return np.zeros((0, 2))
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)
        out = cv2.undistortPointsIter(pts, self.K, self.dist, None,  # type: ignore[call-overload]
                                      None if normalized else self.K, criteria)
        return np.asarray(out, np.float64).reshape(-1, 2)

    def with_pose(self, rot: FloatArray, t: FloatArray) -> CameraModel:
        """Copy with another world->camera pose."""
        return CameraModel(self.name, self.width, self.height, self.K, self.dist, rot, t)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dict (lists), as stored in the stereo YAML."""
        return {'name': self.name, 'width': int(self.width), 'height': int(self.height),
                'K': self.K.tolist(), 'dist': self.dist.tolist(),
                'R': self.R.tolist(), 't': self.t.tolist()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> CameraModel:
        """Inverse of ``to_dict``."""
        return cls(str(data['name']), int(data['width']), int(data['height']),
                   np.array(data['K']), np.array(data['dist']),
                   np.array(data['R']), np.array(data['t']))


@dataclass(frozen=True)
class StereoCalibration:
    """The two calibrated cameras of the rig in the common world frame.

    Attributes:
        side: Cam 1 (side view).
        front: Cam 2 (front view).
        info: free metadata (RMSE per camera [px], number of views, source...).
    """

    side: CameraModel
    front: CameraModel
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def cameras(self) -> tuple[CameraModel, CameraModel]:
        """(side, front)."""
        return (self.side, self.front)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dict as stored in YAML."""
        return {'format': 'dempath-stereo-1', 'side': self.side.to_dict(),
                'front': self.front.to_dict(), 'info': _plain(self.info)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> StereoCalibration:
        """Inverse of ``to_dict``."""
        return cls(CameraModel.from_dict(data['side']), CameraModel.from_dict(data['front']),
                   dict(data.get('info') or {}))

    def save(self, path: str | Path) -> Path:
        """Write the calibration as YAML; returns the path."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(yaml.safe_dump(self.to_dict(), sort_keys=False))
        return path

    @classmethod
    def load(cls, path: str | Path) -> StereoCalibration:
        """Read a stereo YAML written by ``save``.

        Raises:
            CalibrationFileError: missing, unreadable or malformed file.
        """
        path = Path(path)
        try:
            data = yaml.safe_load(path.read_text())
            return cls.from_dict(data)
        except FileNotFoundError as err:
            msg = f'{str(path)!r}: calibration file not found'
            raise CalibrationFileError(msg) from err
        except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError, AttributeError) as err:
            msg = f'{str(path)!r}: not a dempath stereo calibration ({type(err).__name__}: {err})'
            raise CalibrationFileError(msg) from err


def save_stereo(path: str | Path, calib: StereoCalibration) -> Path:
    """Write ``calib`` as YAML (same as ``calib.save(path)``)."""
    return calib.save(path)


def load_stereo(path: str | Path) -> StereoCalibration:
    """Read a stereo YAML (same as ``StereoCalibration.load(path)``)."""
    return StereoCalibration.load(path)


def _plain(value: Any) -> Any:
    """Numpy scalars and arrays -> Python lists and floats, for YAML."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value
