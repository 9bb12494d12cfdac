"""Calibration boards and finding them in an image.

A board is a plane with known points: the inner corners of a checkerboard, or the chessboard corners of a
ChArUco board (a checkerboard whose white squares hold ArUco markers, so a partly visible board still
identifies each corner). Board frame: x along a row of squares, y down the columns, z into the board,
in metres when the square size is given, else in squares (the calibration solves in squares whatever the
unit, so the intrinsics do not depend on it).
Image points are pixels of the image, x right, y down, OpenCV's convention (pixel centres at integers).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from flowvo.errors import FlowvoError

BOARD_KINDS = ("checkerboard", "charuco")
DEFAULT_DICTIONARY = "DICT_4X4_50"  # the smallest 4x4 set: its markers are the easiest to see from afar
MIN_CHARUCO_CORNERS = 8  # fewer corners than this constrain a view's pose (6 unknowns) too weakly
DETECT_MAX_SIDE_PX = 1280  # checkerboards are found on a copy at most this large (phone videos are 4K),
# then refined at full resolution: the search is slow on large frames, the refinement is not
SUBPIX_TERMINATION = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 40, 0.001)  # px


@dataclass(frozen=True)
class Board:
    """A calibration board.

    ``rows`` x ``cols``: inner corners for a checkerboard (a board of 10 x 7 squares has 9 x 6), squares
    for a ChArUco board. ``square_m``: the side of a square in metres (optional for a checkerboard; the
    board frame is then in squares). ChArUco only: ``marker_m``, the side of a marker in the same unit as
    ``square_m``, and the ArUco ``dictionary`` name (OpenCV's, e.g. ``DICT_4X4_50``).
    """

    kind: str
    rows: int
    cols: int
    square_m: float | None = None
    marker_m: float | None = None
    dictionary: str = DEFAULT_DICTIONARY

    def __post_init__(self) -> None:
        if self.kind not in BOARD_KINDS:
            raise FlowvoError(f"unknown board {self.kind!r}; expected one of {', '.join(BOARD_KINDS)}")
        least = 3 if self.kind == "checkerboard" else 2  # OpenCV's checkerboard search needs 3 corners a side
        what = "inner corners" if self.kind == "checkerboard" else "squares"
        if min(self.rows, self.cols) < least:
            raise FlowvoError(f"a {self.kind} needs at least {least} {what} along each side, got "
                              f"{self.rows} x {self.cols}")
        for name in ("square_m", "marker_m"):
            value = getattr(self, name)
            if value is not None and not (np.isfinite(value) and value > 0):
                raise FlowvoError(f"{name.replace('_m', '')} size must be a positive number of metres, got {value}")
        if self.kind == "charuco":
            if self.square_m is None or self.marker_m is None:
                raise FlowvoError("a ChArUco board needs --square and --marker (their ratio places the markers)")
            if self.marker_m >= self.square_m:
                raise FlowvoError(f"the marker ({self.marker_m:g}) must be smaller than the square ({self.square_m:g})")
            dictionary_id(self.dictionary)

    @property
    def corner_grid(self) -> tuple[int, int]:
        """Rows and columns of the corners found on the board."""
        return (self.rows, self.cols) if self.kind == "checkerboard" else (self.rows - 1, self.cols - 1)

    @property
    def unit_m(self) -> float:
        """The length of one square in the board frame's unit."""
        return 1.0 if self.square_m is None else self.square_m

    def describe(self) -> str:
        """One line: kind, size and (when known) the square size."""
        size = "" if self.square_m is None else f", {self.square_m * 1000:g} mm squares"
        if self.kind == "checkerboard":
            return f"checkerboard of {self.rows}x{self.cols} inner corners (rows x columns){size}"
        return (f"ChArUco board of {self.rows}x{self.cols} squares{size}, {self.marker_m * 1000:g} mm markers, "
                f"{self.dictionary}")


def dictionary_id(name: str) -> int:
    """OpenCV's id of the ArUco dictionary ``name`` (``DICT_4X4_50``, ...); a one-line error naming the
    available ones otherwise."""
    value = getattr(cv2.aruco, name, None) if name.startswith("DICT_") else None
    if not isinstance(value, int):
        names = sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_"))
        raise FlowvoError(f"unknown ArUco dictionary {name!r}; expected one of {', '.join(names)}")
    return value


@dataclass(frozen=True)
class BoardView:
    """The board found in one image: ``image_points_px`` (N, 2) float32 and the same corners'
    ``object_points`` (N, 3) float32 in the board frame (z = 0)."""

    image_points_px: np.ndarray
    object_points: np.ndarray


class BoardDetector:
    """Finds ``board`` in grey images (H, W) uint8: :meth:`detect` returns a :class:`BoardView` or None."""

    def __init__(self, board: Board) -> None:
        self.board = board
        rows, cols = board.corner_grid
        if board.kind == "charuco":
            dictionary = cv2.aruco.getPredefinedDictionary(dictionary_id(board.dictionary))
            markers = board.rows * board.cols // 2
            if markers > dictionary.bytesList.shape[0]:
                raise FlowvoError(f"a ChArUco board of {board.rows}x{board.cols} squares holds {markers} markers; "
                                  f"{board.dictionary} has only {dictionary.bytesList.shape[0]}: choose a larger "
                                  "dictionary (e.g. DICT_4X4_100) or the one the board was printed with")
            # OpenCV's board in squares: its detector's tolerances are in the board's unit, so a board given
            # in kilometres or nanometres was never found; the points are scaled to the board's unit after
            self._charuco = cv2.aruco.CharucoBoard((board.cols, board.rows), 1.0, board.marker_m / board.square_m,
                                                   dictionary)
            self._charuco_detector = cv2.aruco.CharucoDetector(self._charuco)
            self.corner_points = (np.asarray(self._charuco.getChessboardCorners(), np.float64).reshape(-1, 3)
                                  * board.unit_m).astype(np.float32)
        else:
            grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * board.unit_m  # row by row, OpenCV's order
            self.corner_points = np.c_[grid, np.zeros(len(grid))].astype(np.float32)

    def outline(self) -> np.ndarray:
        """The four outermost corners of the board's corner grid (4, 2), board frame."""
        low, high = self.corner_points[:, :2].min(axis=0), self.corner_points[:, :2].max(axis=0)
        return np.array([low, [high[0], low[1]], high, [low[0], high[1]]], np.float32)

    def detect(self, image: np.ndarray) -> BoardView | None:
        """The board's corners in ``image`` (grey, H x W uint8), or None where it is not found."""
        if self.board.kind == "charuco":
            return self._detect_charuco(image)
        return self._detect_checkerboard(image)

    def _detect_checkerboard(self, image: np.ndarray) -> BoardView | None:
        rows, cols = self.board.corner_grid
        scale = min(1.0, DETECT_MAX_SIDE_PX / max(image.shape))
        small = image if scale == 1.0 else cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        # OpenCV's default flags; CALIB_CB_FAST_CHECK would skip boards with squares under ~12 px
        flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
        found, corners = cv2.findChessboardCorners(small, (cols, rows), flags=flags)
        if not found:
            return None
        corners = ((corners.reshape(-1, 2) + 0.5) / scale - 0.5).astype(np.float32)  # pixel centres
        grid = corners.reshape(rows, cols, 2)
        spacing = min(np.linalg.norm(np.diff(grid, axis=0), axis=2).min(),
                      np.linalg.norm(np.diff(grid, axis=1), axis=2).min())
        half_window = int(np.clip(spacing / 3, 2, 10))  # well inside a square: never reaches the next corner
        refined = cv2.cornerSubPix(image, corners.reshape(-1, 1, 2), (half_window, half_window), (-1, -1),
                                   SUBPIX_TERMINATION)
        return BoardView(refined.reshape(-1, 2), self.corner_points)

    def _detect_charuco(self, image: np.ndarray) -> BoardView | None:
        corners, ids, _, _ = self._charuco_detector.detectBoard(image)
        if ids is None or len(ids) < MIN_CHARUCO_CORNERS or self._charuco.checkCharucoCornersCollinear(ids):
            return None
        object_points, image_points = self._charuco.matchImagePoints(corners, ids)
        return BoardView(np.asarray(image_points, np.float32).reshape(-1, 2),
                         (np.asarray(object_points, np.float64).reshape(-1, 3) * self.board.unit_m).astype(np.float32))
