"""The camera: pinhole intrinsics, lens distortion, the camera's height above the road and its pitch.

One home for everything that describes a camera, whatever the source (KITTI calib.txt, a calibration file,
command-line flags, a ROS CameraInfo, an estimate from the motion). Pure data and maths over NumPy arrays
(OpenCV for the distortion models); pixels are those of the frames the camera describes, x right, y down.

Distortion models (coefficients in OpenCV's and ROS's order):
- ``plumb_bob`` (radial-tangential, Kalibr's ``radtan``): k1 k2 p1 p2 [k3];
- ``rational_polynomial``: k1 k2 p1 p2 k3 k4 k5 k6;
- ``equidistant`` (fisheye, OpenCV's ``cv2.fisheye``): k1 k2 k3 k4.
Undistorted pixels are those of an ideal pinhole camera with the same intrinsics ``K``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from flowvo.errors import FlowvoError

KITTI_CAMERA_HEIGHT_M = 1.65  # KITTI's left grey camera above the road (its published rig drawing)
MIN_FOCAL_PX = 1.0  # below a pixel no frame is imaged
MAX_FOCAL_PX = 1e5  # a 1e5 px focal length is a 0.6 deg field of view on a 1000 px frame: no odometry
MAX_CAMERA_HEIGHT_M = 10.0  # a camera on a truck cab is ~3 m; beyond 10 m no road scale makes sense
MAX_CAMERA_PITCH_DEG = 30.0  # a camera looking further down sees little but the bonnet and the road at its feet
MAX_CAMERA_ROLL_DEG = 15.0  # a camera rolled further shows the horizon across a third of a KITTI-shaped frame's height
MAX_READOUT_MS = 1000.0  # a rolling shutter reads its rows out within a frame's interval: 1 s at 1 frame/s
LENS_ROUND_TRIP_PX = 0.5  # a frame pixel undistorted and distorted again must land this close to itself
MAX_LENS_STRETCH = 3.0  # the most a lens model may magnify the image radially, relative to its centre (1)

# model name -> accepted coefficient counts
DISTORTION_MODELS: dict[str, tuple[int, ...]] = {
    "none": (0,),
    "plumb_bob": (4, 5),
    "rational_polynomial": (8,),
    "equidistant": (4,),
}
# other names for the same models (ROS, Kalibr, OpenCV usage)
DISTORTION_ALIASES = {"radtan": "plumb_bob", "radial-tangential": "plumb_bob", "pinhole-radtan": "plumb_bob",
                      "fisheye": "equidistant", "pinhole-equi": "equidistant", "equi": "equidistant",
                      "rational": "rational_polynomial", "": "none"}
CAMERA_SOURCES = ("kitti", "calib", "flags", "camera_info", "estimated")


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics in pixels: focal lengths ``fx``, ``fy`` and principal point ``cx``, ``cy``."""

    fx: float
    fy: float
    cx: float
    cy: float

    @property
    def K(self) -> np.ndarray:
        """The 3x3 camera matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @classmethod
    def from_matrix(cls, K: np.ndarray) -> CameraIntrinsics:
        """From a 3x3 (or the left 3x3 of a 3x4 projection) matrix."""
        return cls(float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2]))

    def scaled(self, scale_x: float, scale_y: float) -> CameraIntrinsics:
        """Intrinsics of the image resized by ``scale_x`` (width) and ``scale_y`` (height).

        Pixel centres map as ``x' = (x + 0.5) * s - 0.5``, as cv2.resize samples them.
        """
        return CameraIntrinsics(self.fx * scale_x, self.fy * scale_y,
                                (self.cx + 0.5) * scale_x - 0.5, (self.cy + 0.5) * scale_y - 0.5)


def distortion_model_name(name: str) -> str:
    """The canonical model name of ``name`` (case-insensitive, ROS/Kalibr/OpenCV aliases accepted)."""
    key = name.strip().lower()
    key = DISTORTION_ALIASES.get(key, key)
    if key not in DISTORTION_MODELS:
        raise FlowvoError(f"unknown distortion model {name!r}; expected one of "
                          f"{', '.join(m for m in DISTORTION_MODELS if m != 'none')} (or radtan, fisheye)")
    return key


@dataclass(frozen=True)
class LensDistortion:
    """A lens distortion model and its coefficients (dimensionless, in normalised image coordinates, so
    they do not change when the frames are resized)."""

    model: str = "none"
    coefficients: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        model = distortion_model_name(self.model)
        coefficients = tuple(float(c) for c in self.coefficients)
        if model == "plumb_bob" and len(coefficients) == 0:
            model = "none"
        if not all(math.isfinite(c) for c in coefficients):
            raise FlowvoError(f"distortion coefficients must be finite, got {list(coefficients)}")
        if len(coefficients) not in DISTORTION_MODELS[model]:
            counts = " or ".join(str(n) for n in DISTORTION_MODELS[model])
            raise FlowvoError(f"the {model} distortion model takes {counts} coefficients, got {len(coefficients)}")
        if model != "none" and not any(coefficients):
            model, coefficients = "none", ()
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "coefficients", coefficients)

    @property
    def is_none(self) -> bool:
        return self.model == "none"

    @property
    def D(self) -> np.ndarray:
        """The coefficients as OpenCV takes them (float64)."""
        return np.asarray(self.coefficients, dtype=np.float64)


NO_DISTORTION = LensDistortion()


def undistort_points(points_px: np.ndarray, K: np.ndarray, distortion: LensDistortion) -> np.ndarray:
    """Where distorted pixels ``points_px`` (N, 2) lie in the ideal pinhole image with the same ``K``;
    (N, 2) float32. The identity without distortion."""
    if distortion.is_none or not len(points_px):
        return np.asarray(points_px, dtype=np.float32)
    points = np.ascontiguousarray(points_px, dtype=np.float64).reshape(-1, 1, 2)
    if distortion.model == "equidistant":
        undistorted = cv2.fisheye.undistortPoints(points, K, distortion.D, P=K)
    else:
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 1e-6)  # OpenCV's default 5: too few
        if hasattr(cv2, "undistortPointsIter"):  # OpenCV 4
            undistorted = cv2.undistortPointsIter(points, K, distortion.D, None, K, criteria)
        else:  # OpenCV 5 took the criteria into undistortPoints
            undistorted = cv2.undistortPoints(points, K, distortion.D, R=None, P=K, criteria=criteria)
    return undistorted.reshape(-1, 2).astype(np.float32)


def distort_points(points_px: np.ndarray, K: np.ndarray, distortion: LensDistortion) -> np.ndarray:
    """Where ideal pinhole pixels ``points_px`` (N, 2) appear through the lens (the inverse of
    :func:`undistort_points`); (N, 2) float64."""
    points = np.asarray(points_px, dtype=np.float64).reshape(-1, 2)
    if distortion.is_none or not len(points):
        return points.copy()
    rays = np.c_[(points[:, 0] - K[0, 2]) / K[0, 0], (points[:, 1] - K[1, 2]) / K[1, 1], np.ones(len(points))]
    if distortion.model == "equidistant":
        projected = cv2.fisheye.distortPoints(rays[:, None, :2].copy(), K, distortion.D)
    else:
        projected, _ = cv2.projectPoints(rays[:, None, :], np.zeros(3), np.zeros(3), K, distortion.D)
    return projected.reshape(-1, 2)


def undistortion_maps(image_hw: tuple[int, int], K: np.ndarray, distortion: LensDistortion
                      ) -> tuple[np.ndarray, np.ndarray]:
    """``cv2.remap`` maps that turn a distorted frame (H, W) into the ideal pinhole frame with the same K."""
    h, w = image_hw
    if distortion.model == "equidistant":
        return cv2.fisheye.initUndistortRectifyMap(K, distortion.D, np.eye(3), K, (w, h), cv2.CV_16SC2)
    return cv2.initUndistortRectifyMap(K, distortion.D, None, K, (w, h), cv2.CV_16SC2)


@dataclass(frozen=True)
class Camera:
    """Everything flowvo needs to know about a camera: pinhole ``intrinsics`` (pixels of the frames),
    ``distortion`` of its lens, its ``height_m`` above the road (metres; None: not known, KITTI's 1.65 m is
    then assumed), where the intrinsics came from (``source``, one of :data:`CAMERA_SOURCES`) and
    ``pitch_deg``, how far its optical axis points below the road's plane (degrees, down positive; 0: mounted
    level, as KITTI's), and ``roll_deg``, how far it is then rolled about its optical axis (degrees, right side down
    positive; :func:`mounting_rotation`). ``scaled_from_hw``: (height, width) of the images a calibration file was
    made at, when the frames are another size of the same aspect ratio and the intrinsics were scaled to them; else
    None. ``readout_ms``: a rolling shutter's time between exposing the frame's first (top) and last row
    (milliseconds; 0: a global shutter, as KITTI's)."""

    intrinsics: CameraIntrinsics
    distortion: LensDistortion = field(default=NO_DISTORTION)
    height_m: float | None = None
    source: str = "flags"
    pitch_deg: float = 0.0
    scaled_from_hw: tuple[int, int] | None = None  # the calibration's image size when the frames' differs
    roll_deg: float = 0.0
    readout_ms: float = 0.0

    @property
    def K(self) -> np.ndarray:
        return self.intrinsics.K

    @property
    def camera_height_m(self) -> float:
        """The height above the road the road scale uses, metres (KITTI's when not known)."""
        return KITTI_CAMERA_HEIGHT_M if self.height_m is None else self.height_m

    @property
    def is_level(self) -> bool:
        """Mounted level: neither pitched nor rolled."""
        return not (self.pitch_deg or self.roll_deg)

    @property
    def road_levelling(self) -> np.ndarray:
        """The rotation (3, 3) from the camera frame to the frame of a level camera at the same place, whose
        down axis is the road's normal (:func:`mounting_rotation`)."""
        return mounting_rotation(self.pitch_deg, self.roll_deg)

    def scaled(self, scale_x: float, scale_y: float) -> Camera:
        """The camera of the frames resized by ``scale_x``, ``scale_y`` (distortion, height, mounting and readout
        unchanged)."""
        return Camera(self.intrinsics.scaled(scale_x, scale_y), self.distortion, self.height_m, self.source,
                      self.pitch_deg, self.scaled_from_hw, self.roll_deg, self.readout_ms)

    def record(self) -> dict:
        """The camera as ``run.json`` records it."""
        i = self.intrinsics
        return {"fx": i.fx, "fy": i.fy, "cx": i.cx, "cy": i.cy, "distortion_model": self.distortion.model,
                "distortion": list(self.distortion.coefficients), "camera_height_m": self.camera_height_m,
                "camera_height_given": self.height_m is not None, "camera_pitch_deg": self.pitch_deg,
                "camera_roll_deg": self.roll_deg, "readout_ms": self.readout_ms, "source": self.source,
                **({} if self.scaled_from_hw is None else
                   {"scaled_from_image_size": [self.scaled_from_hw[1], self.scaled_from_hw[0]]})}


def check_camera_height(height_m: float, where: str | None = None) -> float:
    """``height_m`` when it is a plausible camera height above the road; a one-line error otherwise."""
    if not (isinstance(height_m, int | float) and math.isfinite(height_m) and 0 < height_m <= MAX_CAMERA_HEIGHT_M):
        raise FlowvoError(f"camera height must be a finite number of metres in (0, {MAX_CAMERA_HEIGHT_M:g}], "
                          f"got {height_m}", where)
    return float(height_m)


def pitch_rotation(pitch_deg: float) -> np.ndarray:
    """``R_level_cam`` (3, 3): a camera pitched down by ``pitch_deg`` (degrees) about its x axis, in the frame
    of a level camera at the same place (its optical axis there is ``(0, sin, cos)``, y down)."""
    pitch = math.radians(pitch_deg)
    return np.array([[1.0, 0.0, 0.0], [0.0, math.cos(pitch), math.sin(pitch)],
                     [0.0, -math.sin(pitch), math.cos(pitch)]])


def roll_rotation(roll_deg: float) -> np.ndarray:
    """``R_level_cam`` (3, 3): a camera rolled by ``roll_deg`` (degrees) about its optical axis, its right side
    lower when positive, in the frame of an unrolled camera at the same place (its x axis there is ``(cos, sin, 0)``,
    y down)."""
    roll = math.radians(roll_deg)
    return np.array([[math.cos(roll), -math.sin(roll), 0.0], [math.sin(roll), math.cos(roll), 0.0], [0.0, 0.0, 1.0]])


def mounting_rotation(pitch_deg: float, roll_deg: float) -> np.ndarray:
    """``R_level_cam`` (3, 3) of a camera pitched down by ``pitch_deg`` and then rolled by ``roll_deg`` about its own
    optical axis (degrees; :func:`pitch_rotation`, :func:`roll_rotation`)."""
    return pitch_rotation(pitch_deg) @ roll_rotation(roll_deg)


def mounting_of_road_normal(normal: np.ndarray) -> tuple[float, float]:
    """The pitch and roll (degrees, as :func:`mounting_rotation` takes them) of a camera that sees the road's downward
    unit ``normal`` (3,) in its own frame: the inverse of ``mounting_rotation(p, r).T @ (0, 1, 0)``."""
    return math.degrees(math.asin(float(np.clip(normal[2], -1.0, 1.0)))), math.degrees(math.atan2(normal[0], normal[1]))


def check_camera_pitch(pitch_deg: float, where: str | None = None) -> float:
    """``pitch_deg`` when it is a plausible mounting pitch (degrees, down positive); a one-line error otherwise."""
    if not (isinstance(pitch_deg, int | float) and math.isfinite(pitch_deg)
            and abs(pitch_deg) <= MAX_CAMERA_PITCH_DEG):
        raise FlowvoError(f"camera pitch must be a finite number of degrees in [-{MAX_CAMERA_PITCH_DEG:g}, "
                          f"{MAX_CAMERA_PITCH_DEG:g}] (down positive), got {pitch_deg}", where)
    return float(pitch_deg)


def check_camera_roll(roll_deg: float, where: str | None = None) -> float:
    """``roll_deg`` when it is a plausible mounting roll (degrees, right side down positive); a one-line error
    otherwise."""
    if not (isinstance(roll_deg, int | float) and math.isfinite(roll_deg) and abs(roll_deg) <= MAX_CAMERA_ROLL_DEG):
        raise FlowvoError(f"camera roll must be a finite number of degrees in [-{MAX_CAMERA_ROLL_DEG:g}, "
                          f"{MAX_CAMERA_ROLL_DEG:g}] (right side down positive), got {roll_deg}", where)
    return float(roll_deg)


def check_readout(readout_ms: float, where: str | None = None) -> float:
    """``readout_ms`` when it is a plausible rolling-shutter readout time (milliseconds, 0 for a global shutter); a
    one-line error otherwise."""
    if not (isinstance(readout_ms, int | float) and math.isfinite(readout_ms) and 0 <= readout_ms <= MAX_READOUT_MS):
        raise FlowvoError(f"readout time must be a finite number of milliseconds in [0, {MAX_READOUT_MS:g}] (0: a "
                          f"global shutter), got {readout_ms}", where)
    return float(readout_ms)


def check_intrinsics(intrinsics: CameraIntrinsics, image_size_hw: tuple[int, int] | None, where: str | None) -> None:
    """Refuse focal lengths that are not finite or outside [1, 1e5] px and, when the frame size (height,
    width) is known, a principal point outside the frame; ``where`` names the file or flags in the error."""
    values = (intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy)
    if not all(math.isfinite(v) for v in values) or min(intrinsics.fx, intrinsics.fy) < MIN_FOCAL_PX \
            or max(intrinsics.fx, intrinsics.fy) > MAX_FOCAL_PX:
        raise FlowvoError(f"intrinsics must be finite with focal lengths in [{MIN_FOCAL_PX:g}, {MAX_FOCAL_PX:g}] px, "
                          f"got fx={intrinsics.fx} fy={intrinsics.fy} cx={intrinsics.cx} cy={intrinsics.cy}", where)
    if image_size_hw is not None:
        h, w = image_size_hw
        if not (0 <= intrinsics.cx < w and 0 <= intrinsics.cy < h):
            raise FlowvoError(f"principal point ({intrinsics.cx}, {intrinsics.cy}) lies outside the {w}x{h} image",
                              where)


def _border_and_grid_px(image_size_hw: tuple[int, int], per_side: int = 33, grid: int = 9) -> np.ndarray:
    """Pixel centres (N, 2) along the frame's four edges (corners included) and on a coarse grid inside."""
    h, w = image_size_hw
    xs, ys = np.linspace(0.0, w - 1.0, per_side), np.linspace(0.0, h - 1.0, per_side)
    edges = [np.c_[xs, np.zeros(per_side)], np.c_[xs, np.full(per_side, h - 1.0)],
             np.c_[np.zeros(per_side), ys], np.c_[np.full(per_side, w - 1.0), ys]]
    gx, gy = np.meshgrid(np.linspace(0.0, w - 1.0, grid), np.linspace(0.0, h - 1.0, grid))
    return np.concatenate(edges + [np.c_[gx.ravel(), gy.ravel()]])


def check_distortion(intrinsics: CameraIntrinsics, distortion: LensDistortion, image_size_hw: tuple[int, int],
                     where: str | None) -> None:
    """Refuse a lens model that cannot be undone over the frame (height, width): every pixel must undistort
    to an ideal pixel that the model maps back onto it (within :data:`LENS_ROUND_TRIP_PX`), and along the
    ray from the principal point to any such ideal pixel the distorted image must move steadily outwards (a
    lens model that folds back, such as k1 -5 on KITTI's frames, images two directions onto one pixel) and be
    magnified radially at most :data:`MAX_LENS_STRETCH`-fold (k1 80 or 1e6 on KITTI's frames squeeze the whole
    view into a few degrees). Models that fail this gave standstills, unmeasured steps and wrong lengths."""
    if distortion.is_none:
        return
    K = intrinsics.K
    pixels = _border_and_grid_px(image_size_hw)
    ideal = undistort_points(pixels, K, distortion).astype(np.float64)
    back = distort_points(ideal, K, distortion) if np.all(np.isfinite(ideal)) else np.full_like(pixels, np.nan)
    miss = np.linalg.norm(back - pixels, axis=1)
    miss[~np.isfinite(miss)] = np.inf
    h, w = image_size_hw
    model = f"{distortion.model} {' '.join(f'{c:g}' for c in distortion.coefficients)}"
    if miss.max() > LENS_ROUND_TRIP_PX:
        x, y = pixels[int(np.argmax(miss))]
        raise FlowvoError(f"lens distortion {model} cannot be undone over the {w}x{h} frames: pixel ({x:.0f}, "
                          f"{y:.0f}) undistorts to a point the model images "
                          f"{'elsewhere' if not np.isfinite(miss.max()) else f'{miss.max():.1f} px away'} (check "
                          "the coefficients, their order and the model)", where)
    centre = np.array([intrinsics.cx, intrinsics.cy])
    fractions = np.linspace(0.0, 1.0, 65)
    along = centre + fractions[None, :, None] * (ideal - centre)[:, None, :]  # (N, 65, 2) ideal pixels on each ray
    imaged = distort_points(along.reshape(-1, 2), K, distortion).reshape(along.shape)
    ideal_step = np.diff(np.linalg.norm(along - centre, axis=2), axis=1)
    stretch = np.diff(np.linalg.norm(imaged - centre, axis=2), axis=1) / np.maximum(ideal_step, 1e-12)
    stretch[ideal_step < 1e-3] = 1.0  # rays to pixels at the principal point have no length
    worst = np.argmin(stretch.min(axis=1)) if stretch.min() <= 0 else np.argmax(stretch.max(axis=1))
    x, y = pixels[int(worst)]
    if stretch.min() <= 0:
        raise FlowvoError(f"lens distortion {model} folds back within the {w}x{h} frames: towards pixel ({x:.0f}, "
                          f"{y:.0f}) the image stops moving outwards, so two directions meet on one pixel (check the "
                          "coefficients, their order and the model)", where)
    if stretch.max() > MAX_LENS_STRETCH:
        raise FlowvoError(f"lens distortion {model} stretches the image {stretch.max():.3g}-fold towards pixel "
                          f"({x:.0f}, {y:.0f}) of the {w}x{h} frames (a lens stretches it at most "
                          f"{MAX_LENS_STRETCH:g}-fold; check the coefficients, their order and the model)", where)
