"""Calibration targets (ChArUco and plain chessboard) and corner detection.

The twin's board is the paper's: 7 columns x 5 rows of 40.4 mm squares. The paper does not name
the ArUco dictionary; we use ``DICT_5X5_100`` with 30.3 mm markers (0.75 of a square), OpenCV's
current (non-legacy) pattern. Board frame (OpenCV): origin at the outer top-left corner of the
chessboard, x along the columns, y along the rows, z into the board (the printed face looks
along -z). Corner ``i`` sits at column ``i % (columns - 1)``, row ``i // (columns - 1)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from functools import cached_property
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

# The world frame a board defines when it lies on the undisturbed surface, printed face up, rows
# along the tool travel: board axes x, y, z -> world X (lateral), Z (travel), -Y (down), with the
# board's centre at the origin. The calibrator's 'surface' world frame and the twin's first
# (surface) pose both use it; it is a property of the board on the sand, not of the twin.
SURFACE_ROT = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])  # world <- board rotation


class BoardKind(Enum):
    """Kind of calibration target."""

    CHARUCO = 'charuco'
    CHESSBOARD = 'chessboard'


@dataclass(frozen=True)
class BoardSpec:
    """A planar calibration target.

    Attributes:
        columns: number of squares along x.
        rows: number of squares along y.
        square_m: side of a square [m].
        marker_m: side of an ArUco marker [m] (ChArUco only).
        dictionary: OpenCV predefined dictionary name, e.g. ``'DICT_5X5_100'``.
        kind: ChArUco or plain chessboard.
        inverted: printed white-on-black (the grey image is inverted before detection).
        legacy: OpenCV's legacy ChArUco pattern (boards made before OpenCV 4.6 with even rows).
    """

    columns: int = 7
    rows: int = 5
    square_m: float = 0.0404
    marker_m: float = 0.0303
    dictionary: str = 'DICT_5X5_100'
    kind: BoardKind = BoardKind.CHARUCO
    inverted: bool = False
    legacy: bool = False

    def __post_init__(self) -> None:
        if self.columns < 3 or self.rows < 3:
            msg = f'columns/rows: need at least 3x3 squares, got {self.columns}x{self.rows}'
            raise ValueError(msg)
        if not 0 < self.marker_m < self.square_m:
            msg = f'marker_m: must be in (0, square_m={self.square_m}), got {self.marker_m}'
            raise ValueError(msg)
        if not hasattr(cv2.aruco, self.dictionary):
            msg = f'dictionary: unknown OpenCV dictionary {self.dictionary!r}'
            raise ValueError(msg)

    @property
    def n_corners(self) -> int:
        """Number of inner chessboard corners."""
        return (self.columns - 1) * (self.rows - 1)

    @property
    def size_m(self) -> tuple[float, float]:
        """(width, height) of the chessboard area [m]."""
        return self.columns * self.square_m, self.rows * self.square_m

    @property
    def center_m(self) -> FloatArray:
        """(3,) centre of the chessboard in the board frame [m]."""
        w, h = self.size_m
        return np.array([w / 2, h / 2, 0.0])

    @cached_property
    def cv_board(self) -> Any:
        """The ``cv2.aruco.CharucoBoard``."""
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        board = cv2.aruco.CharucoBoard((self.columns, self.rows), self.square_m, self.marker_m,
                                       dictionary)
        board.setLegacyPattern(self.legacy)
        return board

    def object_points(self) -> FloatArray:
        """(n_corners, 3) corner positions in the board frame [m]."""
        nx = self.columns - 1
        ids = np.arange(self.n_corners)
        return np.column_stack([(ids % nx + 1) * self.square_m,
                                (ids // nx + 1) * self.square_m, np.zeros(self.n_corners)])

    def neighbour_pairs(self) -> NDArray[np.int64]:
        """(m, 2) ids of corners one square apart along a row or a column."""
        nx, ny = self.columns - 1, self.rows - 1
        grid = np.arange(self.n_corners).reshape(ny, nx)
        horiz = np.column_stack([grid[:, :-1].ravel(), grid[:, 1:].ravel()])
        vert = np.column_stack([grid[:-1, :].ravel(), grid[1:, :].ravel()])
        return np.vstack([horiz, vert]).astype(np.int64)


PAPER_BOARD = BoardSpec()
CALISCOPE_BOARD = BoardSpec(columns=4, rows=5, square_m=0.054, marker_m=0.0405,
                            dictionary='DICT_4X4_1000', inverted=True)


class CornerDetector:
    """Finds the board's corners in one image at a time.

    Args:
        board: the target.
    """

    CHESSBOARD_MAX_WIDTH = 1000  # wider images are searched at half size, then refined [px]
    MIN_HALF_WINDOW = 3  # smallest cornerSubPix half-window [px]
    MAX_HALF_WINDOW = 5  # largest cornerSubPix half-window [px]; 0.1 of a square in between

    def __init__(self, board: BoardSpec) -> None:
        self.board = board
        self._charuco: Any = None
        if board.kind is BoardKind.CHARUCO:
            from dempath_calib.opencv_check import require_charuco_opencv

            require_charuco_opencv()
            params = cv2.aruco.DetectorParameters()
            params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
            charuco_params = cv2.aruco.CharucoParameters()
            charuco_params.tryRefineMarkers = True
            self._charuco = cv2.aruco.CharucoDetector(board.cv_board, charuco_params, params)

    def detect(self, image: NDArray[np.uint8]) -> FloatArray:
        """Detect corners.

        Args:
            image: (h, w) grey or (h, w, 3) BGR image.

        Returns:
            (n_corners, 2) px corner positions, NaN where a corner was not found.
        """
        grey = np.asarray(image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY),
                          np.uint8)
        if self.board.inverted:
            grey = 255 - grey
        out: FloatArray = np.full((self.board.n_corners, 2), np.nan)
        if self._charuco is None:
            return self._detect_chessboard(grey, out)
        corners, ids, _, _ = self._charuco.detectBoard(grey)
        if ids is not None and len(ids) > 0:
            out[ids.ravel()] = corners.reshape(-1, 2)
            out = self.refine(grey, out)
        return out

    def _detect_chessboard(self, grey: NDArray[np.uint8], out: FloatArray) -> FloatArray:
        """findChessboardCornersSB on a half-size copy of large images, then cornerSubPix."""
        scale = 2 if grey.shape[1] > self.CHESSBOARD_MAX_WIDTH else 1
        small = cv2.resize(grey, None, fx=1 / scale, fy=1 / scale,
                           interpolation=cv2.INTER_AREA) if scale > 1 else grey
        found, corners = cv2.findChessboardCornersSB(
            small, (self.board.columns - 1, self.board.rows - 1),
            flags=cv2.CALIB_CB_ACCURACY | cv2.CALIB_CB_NORMALIZE_IMAGE)
        if not found:
            return out
        out[:] = (corners.reshape(-1, 2) + 0.5) * scale - 0.5  # pixel centres at integers
        return self.refine(grey, out)

    def refine(self, grey: NDArray[np.uint8], corners: FloatArray) -> FloatArray:
        """Re-run ``cv2.cornerSubPix`` on found corners, with a window fitted to the squares.

        OpenCV 4.12's CharucoDetector returns corners offset by about +0.5 px in x and y on
        rendered ground truth (pixel-centre convention); cornerSubPix started from them is
        unbiased (measured: mean offset below 0.02 px on the twin).
        """
        found = ~np.isnan(corners[:, 0])
        pairs = self.board.neighbour_pairs()
        both = found[pairs[:, 0]] & found[pairs[:, 1]]
        if both.any():
            d = np.linalg.norm(corners[pairs[both, 0]] - corners[pairs[both, 1]], axis=1)
            half = int(np.clip(0.1 * np.median(d), self.MIN_HALF_WINDOW, self.MAX_HALF_WINDOW))
        else:
            half = self.MIN_HALF_WINDOW
        pts = corners[found].astype(np.float32).reshape(-1, 1, 2)
        criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-3)
        refined = cv2.cornerSubPix(grey, pts, (half, half), (-1, -1), criteria)
        out = corners.copy()
        out[found] = refined.reshape(-1, 2)
        return out
