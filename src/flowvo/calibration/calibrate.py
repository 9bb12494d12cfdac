"""Intrinsics and lens distortion from views of a calibration board (Zhang's method, OpenCV's solvers).

``calibrate`` finds the board in each image, keeps at most :data:`MAX_VIEWS` distinct, spread-out views,
checks that they can determine the camera, solves, and reports the RMS reprojection error. It refuses,
with a one-line reason, views that cannot determine the camera (criteria and their measured basis below);
it warns (never refuses) about a large reprojection error.

A view is described, without intrinsics, by where the board's outline (the four outer corners of its
corner grid) lies in the image, in fractions of the image's width and height (8 numbers). Views are
chosen farthest-first in that description; a view within :data:`REPEATED_VIEW_DISTANCE` of a chosen one
repeats it (a board held still in a video: its corners moved ~0.7 % of the image) and is not used.

Refusals:
- fewer than :data:`MIN_VIEWS` distinct views with the board: too few to separate intrinsics, distortion
  and the six pose unknowns of each view, and too few to average out corner noise;
- corners in fewer than :data:`MIN_COVERAGE` of the cells of a :data:`COVERAGE_GRID` x
  :data:`COVERAGE_GRID` grid over the image: the distortion is then extrapolated over most of the frame;
- board normals spanning less than :data:`MIN_TILT_SPREAD_DEG` (the largest angle between the board's
  normal in two views): views of parallel planes cannot separate the focal length from the distance
  (Zhang's degenerate case). Measured on 15 simulated views with 0.3 px corner noise (6 seeds): normals
  spanning 8 deg gave fx 7 % off on average (15 % worst), 12 deg 2.7 % (4.7 %), 20 deg 0.8 % (2.4 %),
  30 deg and more 0.8 % (1.5 %).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

from flowvo.calibration.board import Board, BoardDetector, BoardView
from flowvo.camera import CameraIntrinsics, LensDistortion
from flowvo.errors import FlowvoError
from flowvo.progress import progress

# refusal criteria (see the module docstring for why)
MIN_VIEWS = 8
COVERAGE_GRID = 8  # cells per side: each cell is 1/64 of the frame
MIN_COVERAGE = 0.25
MIN_TILT_SPREAD_DEG = 20.0
MAX_VIEWS = 60  # beyond this more views add little and the solver's cost grows with every one
REPEATED_VIEW_DISTANCE = 0.02  # Euclidean, over the outline's 8 coordinates (fractions of the image size)
RMS_WARNING_PX = 1.0  # sharp views of a flat board give 0.1-0.5 px; above 1 px something is off


def _fisheye_flag(name: str) -> int:
    """A cv2.fisheye flag: OpenCV 4 keeps them in cv2.fisheye, OpenCV 5 shares cv2's calibration flags."""
    return getattr(cv2.fisheye, name, None) or getattr(cv2, name)


_FLAGS = {"plumb_bob": 0, "rational_polynomial": cv2.CALIB_RATIONAL_MODEL,
          "equidistant": _fisheye_flag("CALIB_RECOMPUTE_EXTRINSIC") | _fisheye_flag("CALIB_FIX_SKEW")}
COEFFICIENT_NAMES = {"plumb_bob": ("k1", "k2", "p1", "p2", "k3"),  # OpenCV's order, as calibration files hold them
                     "rational_polynomial": ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"),
                     "equidistant": ("k1", "k2", "k3", "k4")}
CALIBRATION_MODELS = tuple(COEFFICIENT_NAMES)


@dataclass(frozen=True)
class CalibrationResult:
    """A calibrated camera and how well its views determine it.

    ``rms_px``: RMS reprojection error over all corners of the views used (pixels); ``view_labels`` and
    ``view_rms_px``: each view used and its own RMS error; ``images_seen``, ``views_found``: images read
    and those showing the board; ``coverage``: fraction of the image grid's cells holding a corner;
    ``tilt_spread_deg``: the largest angle between the board's normals in two views; ``warnings``: lines
    to show the user (the calibration stands).
    """

    intrinsics: CameraIntrinsics
    distortion: LensDistortion
    rms_px: float
    image_size_hw: tuple[int, int]
    images_seen: int
    views_found: int
    view_labels: tuple[str, ...]
    view_rms_px: tuple[float, ...]
    coverage: float
    tilt_spread_deg: float
    warnings: tuple[str, ...]

    @property
    def views_used(self) -> int:
        return len(self.view_labels)


def calibrate(images: Iterable[tuple[str, np.ndarray]], board: Board, model: str = "plumb_bob",
              total: int | None = None) -> CalibrationResult:
    """Calibrate from ``images``: (label, grey image (H, W) uint8) pairs, the label naming the image in
    messages (its file, a video frame). ``model``: one of :data:`CALIBRATION_MODELS`. ``total``: the number
    of images, when known (for the progress bar only)."""
    if model not in CALIBRATION_MODELS:
        raise FlowvoError(f"unknown distortion model {model!r}; expected one of {', '.join(CALIBRATION_MODELS)}")
    detector = BoardDetector(board)
    labels, views, size_hw, seen = _find_views(images, detector, total)
    chosen = spread_views([view_outline(detector, view, size_hw) for view in views], MAX_VIEWS,
                          REPEATED_VIEW_DISTANCE) if views else []
    _check_view_count(len(chosen), len(views), seen, board)
    found, labels, views = len(views), [labels[i] for i in chosen], [views[i] for i in chosen]
    coverage = coverage_fraction([view.image_points_px for view in views], size_hw)
    if coverage < MIN_COVERAGE:
        raise FlowvoError(f"the board's corners cover only {coverage:.0%} of the image (a {COVERAGE_GRID}x"
                          f"{COVERAGE_GRID} grid; at least {MIN_COVERAGE:.0%} needed): move it into the corners "
                          "and edges of the frame, or bring it closer")
    K, D, rotations = _solve(views, size_hw, model)
    errors = [_view_errors(view, rotation, translation, K, D, model) for view, (rotation, translation)
              in zip(views, rotations, strict=True)]
    spread = tilt_spread_deg([rotation for rotation, _ in rotations])
    if spread < MIN_TILT_SPREAD_DEG:
        raise FlowvoError(f"the board faces the camera the same way in every view (its normals span {spread:.0f} "
                          f"deg; at least {MIN_TILT_SPREAD_DEG:g} needed to tell the focal length from the "
                          "distance): tilt it by 20-40 deg left, right, up and down")
    rms = float(np.sqrt(np.mean(np.concatenate(errors) ** 2)))
    warnings = () if rms <= RMS_WARNING_PX else (
        f"RMS reprojection error {rms:.2f} px is above {RMS_WARNING_PX:g} px: blurred or rolling-shutter views, "
        "a board that is not flat, wrong --rows/--cols/--square, or a lens the model does not fit",)
    distortion = LensDistortion(model, tuple(float(c) for c in D.ravel()[:len(COEFFICIENT_NAMES[model])]))
    return CalibrationResult(CameraIntrinsics.from_matrix(K), distortion, rms, (int(size_hw[0]), int(size_hw[1])),
                             seen, found, tuple(labels),
                             tuple(float(np.sqrt(np.mean(e ** 2))) for e in errors), coverage, spread, warnings)


def _find_views(images: Iterable[tuple[str, np.ndarray]], detector: BoardDetector, total: int | None
                ) -> tuple[list[str], list[BoardView], tuple[int, int], int]:
    """The labels and views of the images showing the board, the image size (H, W) and the images seen."""
    labels, views, size_hw, seen = [], [], None, 0
    for label, image in progress(images, "finding the board", total, "image"):
        if size_hw is None:
            size_hw = image.shape[:2]
        elif image.shape[:2] != size_hw:
            raise FlowvoError(f"is {image.shape[1]}x{image.shape[0]}, the first image {size_hw[1]}x{size_hw[0]}: "
                              "all views must come from one camera at one resolution", label)
        seen += 1
        view = detector.detect(image)
        if view is not None:
            labels.append(label)
            views.append(view)
    if seen == 0:
        raise FlowvoError("no images to calibrate from")
    return labels, views, size_hw, seen


def _check_view_count(distinct: int, found: int, seen: int, board: Board) -> None:
    if found == 0:
        hint = (" (inner corners: a board of 7x10 squares has 6x9)" if board.kind == "checkerboard" else
                " (squares), --dictionary, --square and --marker")
        raise FlowvoError(f"the board ({board.describe()}) was not found in any of the {seen} images: check "
                          f"--board, --rows and --cols{hint}")
    if found < MIN_VIEWS:
        raise FlowvoError(f"the board was found in only {found} of {seen} images; calibration needs at least "
                          f"{MIN_VIEWS} views: show it from more positions and angles")
    if distinct < MIN_VIEWS:
        raise FlowvoError(f"the board was found in {found} of {seen} images but from only {distinct} distinct "
                          f"positions (the others repeat them); calibration needs at least {MIN_VIEWS}: move and "
                          "tilt it between views")


def view_outline(detector: BoardDetector, view: BoardView, size_hw: tuple[int, int]) -> np.ndarray:
    """Where the board's outline lies in the image (8,): its four corners in fractions of the image's width
    and height, through the board-to-image homography of the view's corners (so a partly seen ChArUco
    board has one too; a detector returns at least 8 corners, never all on one line)."""
    H, _ = cv2.findHomography(view.object_points[:, :2], view.image_points_px)
    outline = cv2.perspectiveTransform(detector.outline().reshape(-1, 1, 2), H).reshape(-1, 2)
    return (outline / [size_hw[1], size_hw[0]]).ravel()


def spread_views(descriptors: list[np.ndarray], count: int, repeat_distance: float = 0.0) -> list[int]:
    """Indices of at most ``count`` views, in their order, chosen farthest-first: each next view is the one
    farthest (Euclidean distance of ``descriptors``) from those already chosen, starting with the first;
    views within ``repeat_distance`` of a chosen one are repeats, never chosen."""
    points = np.asarray(descriptors, dtype=np.float64)
    chosen = [0]
    distance = np.linalg.norm(points - points[0], axis=1)
    while len(chosen) < count and distance.max() > repeat_distance:
        index = int(np.argmax(distance))
        chosen.append(index)
        distance = np.minimum(distance, np.linalg.norm(points - points[index], axis=1))
    return sorted(chosen)


def coverage_fraction(image_points_px: list[np.ndarray], size_hw: tuple[int, int]) -> float:
    """The fraction of the cells of a :data:`COVERAGE_GRID` square grid over the image (H, W) that hold at
    least one of the points (each (N, 2), pixels)."""
    h, w = size_hw
    points = np.concatenate(image_points_px)
    cells = np.floor(points / [w / COVERAGE_GRID, h / COVERAGE_GRID]).astype(int).clip(0, COVERAGE_GRID - 1)
    return len({(int(x), int(y)) for x, y in cells}) / COVERAGE_GRID ** 2


def tilt_spread_deg(rotation_vectors: list[np.ndarray]) -> float:
    """The largest angle in degrees between the board's normal (its z axis in the camera frame) in any two
    views, given each view's board-to-camera rotation vector (Rodrigues)."""
    normals = np.array([cv2.Rodrigues(np.asarray(r, np.float64).reshape(3))[0][:, 2] for r in rotation_vectors])
    cosines = np.clip(np.abs(normals @ normals.T), 0.0, 1.0)
    return float(np.degrees(np.arccos(cosines.min())))


def _solve(views: list[BoardView], size_hw: tuple[int, int], model: str
           ) -> tuple[np.ndarray, np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
    """K (3, 3), the distortion coefficients and each view's (rotation vector, translation)."""
    size_wh = (int(size_hw[1]), int(size_hw[0]))
    try:
        if model == "equidistant":
            objects = [view.object_points.astype(np.float64).reshape(1, -1, 3) for view in views]
            images = [view.image_points_px.astype(np.float64).reshape(1, -1, 2) for view in views]
            _, K, D, rvecs, tvecs = cv2.fisheye.calibrate(objects, images, size_wh, np.eye(3), np.zeros(4),
                                                          flags=_FLAGS[model])
        else:
            objects = [view.object_points for view in views]
            images = [view.image_points_px.reshape(-1, 1, 2) for view in views]
            _, K, D, rvecs, tvecs = cv2.calibrateCamera(objects, images, size_wh, None, None, flags=_FLAGS[model])
    except cv2.error as error:
        message = str(error).strip().splitlines()[-1]
        raise FlowvoError(f"the {model} calibration failed ({message}): try more varied views") from None
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(D)) and K[0, 0] > 0 and K[1, 1] > 0):
        raise FlowvoError(f"the {model} calibration did not converge (fx={K[0, 0]:g}, fy={K[1, 1]:g}): try more "
                          "varied views")
    return K, D, list(zip(rvecs, tvecs, strict=True))


def _view_errors(view: BoardView, rotation: np.ndarray, translation: np.ndarray, K: np.ndarray, D: np.ndarray,
                 model: str) -> np.ndarray:
    """Each corner's reprojection error in pixels (N,)."""
    if model == "equidistant":
        projected, _ = cv2.fisheye.projectPoints(view.object_points.astype(np.float64).reshape(1, -1, 3),
                                                 rotation, translation, K, D)
    else:
        projected, _ = cv2.projectPoints(view.object_points, rotation, translation, K, D)
    return np.linalg.norm(projected.reshape(-1, 2) - view.image_points_px, axis=1)
