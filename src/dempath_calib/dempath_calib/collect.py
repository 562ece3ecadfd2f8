"""Background collection of calibration views for the node: config and a drop-oldest worker.

Images arrive on the ROS callback thread; detection (~0.1-0.3 s per 1080p image) runs on one
worker thread fed by a size-1 queue per camera that drops the oldest image when a new one
comes (the usual choice for calibration views: any recent view is as good as any other). The
dropped images are counted and reported.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_calib.board import CALISCOPE_BOARD, PAPER_BOARD
from dempath_calib.calibrator import CalibrationConfig, Calibrator
from dempath_calib.intrinsics import DistortionModel

LOG = logging.getLogger(__name__)
BOARD_PRESETS = {'paper': PAPER_BOARD, 'caliscope': CALISCOPE_BOARD}


@dataclass(frozen=True)
class CollectorConfig:
    """Settings of the calibration node.

    Attributes:
        calibration: the calibration settings.
        output_dir: folder for the output files ('' = do not write).
        solve_after_idle_s: solve once when no image came for this long after some did (0 = only
            on the service) [s].
        compressed: subscribe to the compressed image topics (else raw).
    """

    calibration: CalibrationConfig
    output_dir: str = ''
    solve_after_idle_s: float = 0.0
    compressed: bool = True

    def __post_init__(self) -> None:
        if self.solve_after_idle_s < 0:
            msg = f'solve_after_idle_s: must be >= 0, got {self.solve_after_idle_s}'
            raise ValueError(msg)

    @classmethod
    def from_params(cls, p: Mapping[str, Any]) -> CollectorConfig:
        """Build from plain parameter values (board, square_m, distortion, world, min_views,
        offset_s (NaN = estimate), image_width, image_height, output_dir, solve_after_idle_s,
        compressed)."""
        if p['board'] not in BOARD_PRESETS:
            msg = f'board: must be one of {sorted(BOARD_PRESETS)}, got {p["board"]!r}'
            raise ValueError(msg)
        board = BOARD_PRESETS[p['board']]
        if p['square_m'] > 0:
            ratio = board.marker_m / board.square_m
            board = replace(board, square_m=p['square_m'], marker_m=ratio * p['square_m'])
        offset = None if math.isnan(p['offset_s']) else float(p['offset_s'])
        calib = CalibrationConfig(
            board=board, distortion=DistortionModel(p['distortion']), world=p['world'],
            min_views=int(p['min_views']), offset_s=offset,
            image_size=(int(p['image_width']), int(p['image_height'])))
        return cls(calib, str(p['output_dir']), float(p['solve_after_idle_s']),
                   bool(p['compressed']))

    @property
    def output_path(self) -> Path | None:
        """The output folder, or None."""
        return Path(self.output_dir) if self.output_dir else None


class ViewCollector:
    """Runs detection on a worker thread; at most one pending image per camera.

    Args:
        calibrator: receives the detections.
    """

    def __init__(self, calibrator: Calibrator) -> None:
        self.calibrator = calibrator
        self.dropped = [0, 0]
        self._pending: list[tuple[float, NDArray[np.uint8]] | None] = [None, None]
        self._cond = threading.Condition()
        self._busy = False
        self._stop = False
        self._thread = threading.Thread(target=self._run, name='calib-detect', daemon=True)
        self._thread.start()

    def put(self, camera: int, stamp_s: float, image: NDArray[np.uint8]) -> None:
        """Queue an image (replacing, and counting, a pending one of the same camera)."""
        with self._cond:
            if self._pending[camera] is not None:
                self.dropped[camera] += 1
            self._pending[camera] = (stamp_s, image)
            self._cond.notify()

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._stop and all(p is None for p in self._pending):
                    self._cond.wait()
                if self._stop:
                    return
                cam = 0 if self._pending[0] is not None else 1
                item = self._pending[cam]
                self._pending[cam] = None
                self._busy = True
            assert item is not None
            self.calibrator.add_image(cam, item[0], item[1])
            with self._cond:
                self._busy = False
                self._cond.notify_all()

    def drain(self, timeout_s: float = 30.0) -> bool:
        """Wait until every queued image is processed; returns False on timeout."""
        with self._cond:
            return self._cond.wait_for(
                lambda: not self._busy and all(p is None for p in self._pending), timeout_s)

    def close(self) -> None:
        """Stop the worker thread."""
        with self._cond:
            self._stop = True
            self._cond.notify_all()
        self._thread.join(timeout=5.0)
