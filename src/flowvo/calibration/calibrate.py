"""Intrinsics and lens distortion from views of a calibration board (Zhang's method, OpenCV's solvers).

``calibrate`` finds the board in each image, keeps at most :data:`MAX_VIEWS` distinct, spread-out views,
checks that they can determine the camera, solves, and reports the RMS reprojection error. It refuses,
with a one-line reason, views that cannot determine the camera (criteria and their measured basis below);
it warns (never refuses) about a large reprojection error.

Real photo sets: images whose size differs from that of most views of the board (a photo cropped or
re-saved by some tool) are skipped, named in a warning; images where the board is not found are named in
the result. Only too few usable views remaining is refused. The solvers work in units of squares
(``_solve``), so the square size given never changes the intrinsics.

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
MAX_NAMED = 12  # images named in a message; more are counted


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
    to show the user (the calibration stands); ``without_board``: the images (of the size used) where the
    board was not found; ``skipped_for_size``: the images skipped because their size differs from most
    images' (``images_seen`` counts only those of the size used).
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
    without_board: tuple[str, ...] = ()
    skipped_for_size: tuple[str, ...] = ()

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
    search = _find_views(images, detector, total)
    size_hw = _majority_size(search)
    size_warning = _size_warning(search, size_hw)
    seen, without_board = len(search.images[size_hw]), tuple(search.without_board.get(size_hw, ()))
    labels, views = [label for label, _ in search.views.get(size_hw, ())], [v for _, v in search.views.get(size_hw, ())]
    chosen = spread_views([view_outline(detector, view, size_hw) for view in views], MAX_VIEWS,
                          REPEATED_VIEW_DISTANCE) if views else []
    _check_view_count(len(chosen), len(views), seen, board, size_hw if size_warning else None, without_board)
    found, labels, views = len(views), [labels[i] for i in chosen], [views[i] for i in chosen]
    coverage = coverage_fraction([view.image_points_px for view in views], size_hw)
    if coverage < MIN_COVERAGE:
        raise FlowvoError(f"the board's corners cover only {coverage:.0%} of the image (a {COVERAGE_GRID}x"
                          f"{COVERAGE_GRID} grid; at least {MIN_COVERAGE:.0%} needed): move it into the corners "
                          "and edges of the frame, or bring it closer")
    K, D, rotations = _solve(views, size_hw, model, board.unit_m)
    errors = [_view_errors(view, rotation, translation, K, D, model) for view, (rotation, translation)
              in zip(views, rotations, strict=True)]
    spread = tilt_spread_deg([rotation for rotation, _ in rotations])
    if spread < MIN_TILT_SPREAD_DEG:
        raise FlowvoError(f"the board faces the camera the same way in every view (its normals span {spread:.0f} "
                          f"deg; at least {MIN_TILT_SPREAD_DEG:g} needed to tell the focal length from the "
                          "distance): tilt it by 20-40 deg left, right, up and down")
    rms = float(np.sqrt(np.mean(np.concatenate(errors) ** 2)))
    warnings = () if size_warning is None else (size_warning,)
    if rms > RMS_WARNING_PX:
        warnings += (f"RMS reprojection error {rms:.2f} px is above {RMS_WARNING_PX:g} px: blurred or rolling-shutter "
                     "views, a board that is not flat, wrong --rows/--cols/--square, or a lens the model does not fit",)
    distortion = LensDistortion(model, tuple(float(c) for c in D.ravel()[:len(COEFFICIENT_NAMES[model])]))
    return CalibrationResult(CameraIntrinsics.from_matrix(K), distortion, rms, (int(size_hw[0]), int(size_hw[1])),
                             seen, found, tuple(labels),
                             tuple(float(np.sqrt(np.mean(e ** 2))) for e in errors), coverage, spread, warnings,
                             without_board, tuple(label for size, names in search.images.items() if size != size_hw
                                                  for label in names))


@dataclass
class _Found:
    """What the search found: per image size (H, W), the labels and views of the images showing the board,
    the labels of those that do not, and the labels of all, in order."""

    images: dict[tuple[int, int], list[str]]
    views: dict[tuple[int, int], list[tuple[str, BoardView]]]
    without_board: dict[tuple[int, int], list[str]]


def _find_views(images: Iterable[tuple[str, np.ndarray]], detector: BoardDetector, total: int | None) -> _Found:
    """The board searched in every image; images grouped by their size (photos of another size than most,
    e.g. cropped or re-saved by some tool, are skipped later rather than refusing the set)."""
    found = _Found({}, {}, {})
    for label, image in progress(images, "finding the board", total, "image"):
        size_hw = (int(image.shape[0]), int(image.shape[1]))
        found.images.setdefault(size_hw, []).append(label)
        view = detector.detect(image)
        if view is None:
            found.without_board.setdefault(size_hw, []).append(label)
        else:
            found.views.setdefault(size_hw, []).append((label, view))
    if not found.images:
        raise FlowvoError("no images to calibrate from")
    return found


def _majority_size(found: _Found) -> tuple[int, int]:
    """The image size (H, W) of most views of the board (so a few odd photos never outvote the views that
    can calibrate); a tie goes to the size of more images, then to the size seen first."""
    sizes = list(found.images)  # in the order first seen
    return max(sizes, key=lambda size: (len(found.views.get(size, ())), len(found.images[size]), -sizes.index(size)))


def _size_warning(found: _Found, size_hw: tuple[int, int]) -> str | None:
    """The warning naming the images skipped for their size, or None when all share ``size_hw``."""
    skipped = [(label, size) for size, labels in found.images.items() if size != size_hw for label in labels]
    if not skipped:
        return None
    seen = sum(len(labels) for labels in found.images.values())
    names = ", ".join(f"{label} ({w}x{h})" for label, (h, w) in skipped[:MAX_NAMED])
    more = f" and {len(skipped) - MAX_NAMED} more" if len(skipped) > MAX_NAMED else ""
    return (f"{len(skipped)} of {seen} images skipped: their size differs from the {size_hw[1]}x{size_hw[0]} of "
            f"the images used (intrinsics are in pixels of one resolution): {names}{more}")


def named(labels: list[str] | tuple[str, ...], limit: int | None = None) -> str:
    """``labels`` as one comma-separated list, at most ``limit`` (default :data:`MAX_NAMED`) of them named."""
    limit = MAX_NAMED if limit is None else limit
    more = f" and {len(labels) - limit} more" if len(labels) > limit else ""
    return ", ".join(labels[:limit]) + more


def _check_view_count(distinct: int, found: int, seen: int, board: Board, size_hw: tuple[int, int] | None,
                      without_board: tuple[str, ...]) -> None:
    """Refuse too few views. ``size_hw``: the size of the images used when others were skipped (None when all
    share it); ``without_board``: the images where the board was not found (named when only a few)."""
    images = f"{seen} images" + ("" if size_hw is None else f" of {size_hw[1]}x{size_hw[0]} (others skipped for "
                                                          "their size)")
    if found == 0:
        hint = (" (inner corners: a board of 7x10 squares has 6x9)" if board.kind == "checkerboard" else
                " (squares), --dictionary, --square and --marker")
        raise FlowvoError(f"the board ({board.describe()}) was not found in any of the {images}: check "
                          f"--board, --rows and --cols{hint}")
    if found < MIN_VIEWS:
        missing = f" (not in {named(without_board)})" if len(without_board) <= MAX_NAMED else ""
        raise FlowvoError(f"the board was found in only {found} of {images}{missing}; calibration needs at least "
                          f"{MIN_VIEWS} views: show it from more positions and angles")
    if distinct < MIN_VIEWS:
        raise FlowvoError(f"the board was found in {found} of {images} but from only {distinct} distinct "
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


def _solve(views: list[BoardView], size_hw: tuple[int, int], model: str, unit_m: float
           ) -> tuple[np.ndarray, np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
    """K (3, 3), the distortion coefficients and each view's (rotation vector, translation in the board
    frame's unit). The solvers work in units of squares (board points divided by ``unit_m``, one square's
    length in the board frame's unit) and the translations are scaled back: OpenCV's solvers stop on a
    change relative to all their parameters, translations included, so boards in kilometres or nanometres
    stopped them early (a square of 1e6 put cy 12 px off on one set of views). Both boards' corners lie on
    the squares' grid, so in squares they are whole numbers: rounded, the same whatever the unit (bit for
    bit)."""
    size_wh = (int(size_hw[1]), int(size_hw[0]))
    objects = [np.round(np.asarray(view.object_points, np.float64) / unit_m) for view in views]
    try:
        if model == "equidistant":
            objects = [points.reshape(1, -1, 3) for points in objects]
            images = [view.image_points_px.astype(np.float64).reshape(1, -1, 2) for view in views]
            _, K, D, rvecs, tvecs = cv2.fisheye.calibrate(objects, images, size_wh, np.eye(3), np.zeros(4),
                                                          flags=_FLAGS[model])
        else:
            objects = [points.astype(np.float32) for points in objects]
            images = [view.image_points_px.reshape(-1, 1, 2) for view in views]
            _, K, D, rvecs, tvecs = cv2.calibrateCamera(objects, images, size_wh, None, None, flags=_FLAGS[model])
    except cv2.error as error:
        message = str(error).strip().splitlines()[-1]
        raise FlowvoError(f"the {model} calibration failed ({message}): try more varied views") from None
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(D)) and K[0, 0] > 0 and K[1, 1] > 0):
        raise FlowvoError(f"the {model} calibration did not converge (fx={K[0, 0]:g}, fy={K[1, 1]:g}): try more "
                          "varied views")
    return K, D, [(rotation, np.asarray(translation, np.float64) * unit_m) for rotation, translation
                  in zip(rvecs, tvecs, strict=True)]


def _view_errors(view: BoardView, rotation: np.ndarray, translation: np.ndarray, K: np.ndarray, D: np.ndarray,
                 model: str) -> np.ndarray:
    """Each corner's reprojection error in pixels (N,)."""
    if model == "equidistant":
        projected, _ = cv2.fisheye.projectPoints(view.object_points.astype(np.float64).reshape(1, -1, 3),
                                                 rotation, translation, K, D)
    else:
        projected, _ = cv2.projectPoints(view.object_points, rotation, translation, K, D)
    return np.linalg.norm(projected.reshape(-1, 2) - view.image_points_px, axis=1)
