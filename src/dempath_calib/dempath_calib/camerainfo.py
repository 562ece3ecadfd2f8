"""Camera files in the ROS camera_info YAML format (as camera_calibration_parsers reads them).

Keys: image_width, image_height, camera_name, camera_matrix, distortion_model ('plumb_bob' =
k1 k2 p1 p2 k3), distortion_coefficients, rectification_matrix, projection_matrix; matrices are
``{rows, cols, data}`` in row-major order. A monocular camera has R = I and P = [K | 0].
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml  # type: ignore[import-untyped]

from dempath_calib.camera import CameraModel
from dempath_calib.errors import CalibrationFileError


def _matrix(rows: int, cols: int, values: Any) -> dict[str, Any]:
    return {'rows': rows, 'cols': cols,
            'data': [float(v) for v in np.asarray(values, dtype=np.float64).ravel()]}


def camera_info_dict(camera: CameraModel) -> dict[str, Any]:
    """The camera_info YAML content of ``camera`` (pose not included: see the stereo file)."""
    return {'image_width': int(camera.width), 'image_height': int(camera.height),
            'camera_name': camera.name, 'camera_matrix': _matrix(3, 3, camera.K),
            'distortion_model': 'plumb_bob',
            'distortion_coefficients': _matrix(1, 5, camera.dist),
            'rectification_matrix': _matrix(3, 3, np.eye(3)),
            'projection_matrix': _matrix(3, 4, np.hstack([camera.K, np.zeros((3, 1))]))}


def write_camera_info(path: str | Path, camera: CameraModel) -> Path:
    """Write ``camera`` as a camera_info YAML file; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(camera_info_dict(camera), sort_keys=False))
    return path


def read_camera_info(path: str | Path) -> CameraModel:
    """Read a camera_info YAML file into a CameraModel (identity pose).

    Raises:
        CalibrationFileError: missing file, bad YAML, missing key or wrong matrix size.
    """
    path = Path(path)
    if not path.is_file():
        msg = f'{str(path)!r}: camera_info file not found'
        raise CalibrationFileError(msg)
    try:
        data = yaml.safe_load(path.read_text())
        k = np.array(data['camera_matrix']['data'], dtype=np.float64).reshape(3, 3)
        d = np.zeros(5)
        coeffs = np.array(data['distortion_coefficients']['data'], dtype=np.float64)
        d[:min(5, len(coeffs))] = coeffs[:5]
        return CameraModel(str(data.get('camera_name', path.stem)), int(data['image_width']),
                           int(data['image_height']), k, d)
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as err:
        msg = f'{str(path)!r}: not a camera_info YAML file ({type(err).__name__}: {err})'
        raise CalibrationFileError(msg) from err
