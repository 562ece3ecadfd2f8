"""The demo's calibration: ChArUco views of a recording -> stereo YAML, field segment, truth check.

The rendered field recording starts with a board segment (the board lying on the sand, then
moved through the shared view) and goes on with the field frames. :func:`calibrate_recording`
detects the board in every image of a bag or frame folder, calibrates both cameras from the
images that show it, and finds where the field segment starts (the first image after the last
one with a board), so that nothing about the recording's layout is hard-coded.
:func:`check_against_truth` compares the result with the cameras a synthetic recording's truth
file names (the product never reads it; the demo prints the check beside the figures).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dempath.errors import DempathError
from dempath.topics import CAMERAS

MIN_VIEWS = 4  # least board views per camera (the bundled render has 6, remade ones 12)
RUN_GAP = 3.0  # an image this many frame intervals before the next is not a field frame


@dataclass(frozen=True)
class CalibrationRun:
    """What the calibration of a recording gave.

    Attributes:
        result: the calibrator's result (``dempath_calib.calibrator.CalibrationResult``).
        board_stamps: (camera, stamp s) of every image with a usable board view.
        field_start_s: stamp of the first image after the last board view [s] (None: none).
        first_stamp_s: the earliest image stamp [s].
        image_size: (width, height) px of the images.
    """

    result: Any
    board_stamps: tuple[tuple[int, float], ...]
    field_start_s: float | None
    first_stamp_s: float
    image_size: tuple[int, int]


def calibrate_recording(source_path: Path, note: Callable[[int, int, str], None],
                        ) -> CalibrationRun:
    """Calibrate both cameras from the board views of a bag or a frame folder.

    Args:
        source_path: a rosbag2 folder (CompressedImage or Image per camera) or a frame folder.
        note: ``note(done, total, line)`` progress callback.

    Raises:
        DempathError: unreadable input, one camera missing, images of mixed sizes, too few
            board views (each names the input and the fault).
    """
    from dempath_calib.calibrator import CalibrationConfig, Calibrator

    source = _open(source_path)
    total = source.count()
    cal: Calibrator | None = None
    sizes: dict[int, tuple[int, int]] = {}
    boards: list[tuple[int, float]] = []
    stamps: list[tuple[int, float]] = []
    for done, (cam, stamp, image) in enumerate(source.frames(), 1):
        size = (int(image.shape[1]), int(image.shape[0]))
        first = sizes.setdefault(cam, size)
        if size != first:
            msg = (f'{source_path}: {CAMERAS[cam]} image at {stamp:.3f} s is {size[0]}x'
                   f'{size[1]} px, its earlier images are {first[0]}x{first[1]} px (mixed sizes)')
            raise DempathError(msg)
        if cal is None:
            cal = Calibrator(CalibrationConfig(image_size=size, min_views=MIN_VIEWS))
        if cal.add_image(cam, stamp, image) >= cal.config.min_corners:
            boards.append((cam, stamp))
        stamps.append((cam, stamp))
        note(done, total, cal.progress().line())
    if cal is None or len(sizes) < 2:
        msg = f'{source_path}: images of {len(sizes)} camera(s); the calibration needs two'
        raise DempathError(msg)
    if sizes[0] != sizes[1]:
        msg = f'{source_path}: the cameras have different image sizes {sizes[0]} and {sizes[1]}'
        raise DempathError(msg)
    result = _solve(cal, source_path)
    return CalibrationRun(result, tuple(boards), field_start(stamps, max(s for _, s in boards)),
                          min(s for _, s in stamps), sizes[0])


def field_start(stamps: list[tuple[int, float]], last_board_s: float) -> float | None:
    """Stamp of the first image of the field segment [s], None when there is none.

    The field segment is what follows the last board image at the cameras' frame rate: per
    camera, images after ``last_board_s`` that are followed by the camera's next image more
    than ``RUN_GAP`` median intervals later are the board segment's tail (a view in which the
    board was not found), not the field frames.
    """
    firsts = []
    for cam in {c for c, _ in stamps}:
        t = np.sort([s for c, s in stamps if c == cam and s > last_board_s])
        if len(t) == 0:
            continue
        gaps = np.diff(t)
        if len(gaps) == 0:
            firsts.append(float(t[0]))
            continue
        step = float(np.median(gaps))
        k = 0
        while k < len(gaps) and gaps[k] > RUN_GAP * step:
            k += 1
        firsts.append(float(t[k]))
    return min(firsts) if firsts else None


def _open(path: Path) -> Any:
    from dempath_calib.errors import InputSourceError
    from dempath_calib.sources import open_source

    try:
        source = open_source([str(path)])
        source.count()
    except InputSourceError as err:
        raise DempathError(str(err)) from err
    return source


def _solve(cal: Any, path: Path) -> Any:
    """Intrinsics per camera, then the views paired with the nearest frame of the other camera.

    The board is held still for each view of a calibration segment, so a frame of the other
    camera a few ms away (unsynchronised cameras) shows the same pose: pairing without
    interpolating the corners in time (``Calibrator.solve`` interpolates, which is right for a
    board moving through a video but leaves the first view unpaired when the other camera
    exposes a little later).
    """
    from dempath_calib.calibrator import CAMERA_NAMES, calibrate_detections
    from dempath_calib.errors import CalibrationError
    from dempath_calib.intrinsics import calibrate_intrinsics
    from dempath_calib.pairing import pair_frames

    cfg = cal.config
    try:
        intr = tuple(calibrate_intrinsics(CAMERA_NAMES[c], cal.streams[c].arrays()[1], cfg.board,
                                          cfg.image_size, cfg.distortion, cfg.min_views,
                                          cfg.min_corners) for c in range(2))
        stamps, corners = pair_frames(cal.streams[0], cal.streams[1], offset_s=0.0,
                                      interpolate=False)
        result = calibrate_detections(corners, stamps, cfg, intr)
        result.report.update({'offset_s': 0.0, 'progress': cal.progress()._asdict(),
                              'pairing': 'nearest frame, board still per view'})
        return result
    except (CalibrationError, ValueError) as err:
        msg = f'{path}: calibration failed ({err})'
        raise DempathError(msg) from err


def truth_cameras(truth_json: Path) -> dict[str, Any]:
    """``{name: CameraModel}`` of a synthetic recording's truth file ({} when absent)."""
    from dempath_calib.camera import CameraModel

    if not truth_json.is_file():
        return {}
    data = json.loads(truth_json.read_text())
    return {c['name']: CameraModel.from_dict(c) for c in data.get('cameras', [])}


def check_against_truth(calibration: Any, truth: dict[str, Any]) -> list[dict[str, Any]]:
    """Per camera: focal length and principal point errors, centre and orientation errors.

    Returns:
        one row per camera: ``camera, fx_pct, fy_pct, cx_px, cy_px, centre_mm, angle_deg``.
    """
    rows = []
    for cam in calibration.cameras:
        ref = truth.get(cam.name)
        if ref is None:
            continue
        centre = -cam.R.T @ cam.t
        ref_centre = -ref.R.T @ ref.t
        rel = cam.R @ ref.R.T
        angle = np.degrees(np.arccos(np.clip((np.trace(rel) - 1) / 2, -1.0, 1.0)))
        rows.append({'camera': cam.name,
                     'fx_pct': 100 * (cam.K[0, 0] / ref.K[0, 0] - 1),
                     'fy_pct': 100 * (cam.K[1, 1] / ref.K[1, 1] - 1),
                     'cx_px': float(cam.K[0, 2] - ref.K[0, 2]),
                     'cy_px': float(cam.K[1, 2] - ref.K[1, 2]),
                     'centre_mm': float(1e3 * np.linalg.norm(centre - ref_centre)),
                     'angle_deg': float(angle)})
    return rows


def truth_lines(rows: list[dict[str, Any]]) -> str:
    """The truth check as printable lines."""
    return '\n'.join(
        f"against the truth, {r['camera']}: fx {r['fx_pct']:+.2f} %, fy {r['fy_pct']:+.2f} %, "
        f"principal point ({r['cx_px']:+.1f}, {r['cy_px']:+.1f}) px, centre "
        f"{r['centre_mm']:.1f} mm, orientation {r['angle_deg']:.2f} deg" for r in rows)
