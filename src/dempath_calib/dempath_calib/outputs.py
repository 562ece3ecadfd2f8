"""Files a calibration writes into its output folder.

- ``cam_side.yaml``, ``cam_front.yaml``: ROS camera_info YAML (camera_calibration_parsers);
- ``stereo.yaml``: both cameras with their world->camera poses (``StereoCalibration``);
- ``point_set.npz`` and ``point_set.csv``: the calibration point set (``pointset``);
- ``report.json``: RMSE, views, corner spacing, per-view errors, world frames.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from dempath.errors import OutputError
from dempath_calib.calibrator import CalibrationResult
from dempath_calib.camerainfo import write_camera_info
from dempath_calib.pointset import save_point_set

OUTPUT_FILES = ('cam_side.yaml', 'cam_front.yaml', 'stereo.yaml', 'point_set.npz',
                'point_set.csv', 'report.json')


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return str(value)


def save_result(result: CalibrationResult, out_dir: str | Path,
                extra: dict[str, Any] | None = None) -> dict[str, Path]:
    """Write every output file of ``result`` into ``out_dir``; returns name -> path.

    Raises:
        OutputError: the folder cannot be created or written.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
        paths = {
            'cam_side.yaml': write_camera_info(out / 'cam_side.yaml', result.calibration.side),
            'cam_front.yaml': write_camera_info(out / 'cam_front.yaml',
                                                result.calibration.front),
            'stereo.yaml': result.calibration.save(out / 'stereo.yaml'),
            'point_set.npz': save_point_set(out / 'point_set.npz', result.point_set),
            'point_set.csv': save_point_set(out / 'point_set.csv', result.point_set),
        }
        report = {**result.report, **(extra or {})}
        (out / 'report.json').write_text(json.dumps(report, indent=1, default=_json_default))
        paths['report.json'] = out / 'report.json'
    except OSError as err:
        msg = f'{out}: cannot write calibration outputs ({err})'
        raise OutputError(msg) from err
    return paths
