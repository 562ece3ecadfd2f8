"""The TF frames of a node graph: world, scene, field, both cameras (docs/ros.md, "Frames").

The recorder writes them to ``/tf_static`` of every bag the graph records (``frames_file``), so
Foxglove places the cameras, the measured markers (``field``), the model's particles and tool
(``scene``) together. The field frame's origin in the scene is the centre of the scene's marker
grid on the surface (Y = 0): where the calibration board lay (docs/demo.md).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath.frames import Transform, check_tree, save_frames, scene_transforms


def marker_grid_centre(markers: Any) -> NDArray[np.float64]:
    """(3,) m: the centre of a scene's marker grid (``MarkerSpec``) on the surface, scene frame.

    Row ``r`` lies at X = x_m + r * side * spacing_x_m, column ``c`` at Z = first_z_m +
    c * spacing_z_m (dempath_sim.scene.spec.MarkerSpec).
    """
    x = markers.x_m + markers.side * markers.spacing_x_m * (markers.rows - 1) / 2
    z = markers.first_z_m + markers.spacing_z_m * (markers.columns - 1) / 2
    return np.array([x, 0.0, z])


def graph_frames(calibration: str | Path, scene: str) -> list[Transform]:
    """world -> scene -> field -> both cameras' optical frames, for a calibration and a scene.

    Raises:
        DempathError: the calibration or the scene cannot be read (one line naming it).
    """
    from dempath_calib.camera import StereoCalibration
    from dempath_calib.frames import camera_frames
    from dempath_sim.scene.loader import resolve_scene

    origin = marker_grid_centre(resolve_scene(scene).markers)
    transforms = scene_transforms(origin) + camera_frames(StereoCalibration.load(calibration))
    check_tree(transforms)
    return transforms


def write_graph_frames(path: str | Path, calibration: str | Path, scene: str) -> Path:
    """:func:`graph_frames` as the recorder's ``frames_file`` YAML at ``path``."""
    return save_frames(path, graph_frames(calibration, scene))
