"""Camera calibration files, whatever tool wrote them, read into one :class:`CameraFile`.

Kinds (recognised by their content, not their name):
- KITTI ``calib.txt``: ``P0: 12 numbers`` (pinhole); flowvo also reads optional ``distortion_model: NAME``,
  ``distortion: k1 k2 ...`` and ``camera_height_m: H`` lines there.
- OpenCV ``FileStorage`` YAML or XML (``cv::FileStorage``, ``cv2.FileStorage``): ``camera_matrix``,
  ``distortion_coefficients`` (4, 5 or 8: plumb-bob or rational), optional ``distortion_model``,
  ``image_width``/``image_height``, ``camera_height_m``.
- ROS ``camera_calibration`` / ``camera_info_manager`` YAML: ``camera_matrix.data``, ``distortion_model``,
  ``distortion_coefficients.data``, ``image_width``/``image_height`` (what ``flowvo calibrate`` writes,
  with ``camera_height_m`` when known).
- Kalibr camchain YAML: ``cam0: {camera_model: pinhole, intrinsics: [fu, fv, pu, pv], distortion_model:
  radtan|equidistant|none, distortion_coeffs: [...], resolution: [w, h]}`` (the first camera).
Numbers are checked where they are read: one line naming the file and what is wrong.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from flowvo.camera import CameraIntrinsics, LensDistortion, check_camera_height, check_intrinsics
from flowvo.errors import FlowvoError

MAX_CALIBRATION_BYTES = 1_000_000  # calibration files are a few kB; anything larger is not one
MAX_IMAGE_SIDE_PX = 100_000  # an image side stated by a calibration file; beyond it no camera


@dataclass(frozen=True)
class CameraFile:
    """What a calibration file says: intrinsics (pixels), lens distortion, the camera height above the road
    (metres, when the file has it), the image size (height, width) it was calibrated at (when stated), the
    kind of file, and the camera's pitch below the road and roll (degrees) and its rolling shutter's readout time
    (milliseconds), when the file has them (KITTI calib.txt)."""

    intrinsics: CameraIntrinsics
    distortion: LensDistortion
    height_m: float | None
    image_size_hw: tuple[int, int] | None
    kind: str
    pitch_deg: float | None = None
    roll_deg: float | None = None
    readout_ms: float | None = None


def read_camera_file(path: str | Path) -> CameraFile:
    """Read any supported calibration file (see the module docstring)."""
    path = Path(path)
    if not path.is_file():
        raise FlowvoError("calibration file not found" if not path.exists() else
                          "is not a regular file (a folder, a FIFO or a device): give a calibration file", path)
    if path.stat().st_size > MAX_CALIBRATION_BYTES:
        raise FlowvoError(f"is {path.stat().st_size} bytes: too large for a calibration file", path)
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")  # a byte-order mark (Windows editors write one) is no content
    except UnicodeDecodeError:
        raise FlowvoError("not a calibration file (not UTF-8 text)", path) from None
    stripped = text.lstrip()
    try:
        if stripped.startswith("<?xml") or stripped.startswith("<opencv_storage") \
                or stripped.startswith("%YAML:") or "!!opencv-matrix" in text:
            return _opencv_storage(text, path)
        if _looks_like_kitti(text):
            return _kitti(path)
        return _yaml(text, path)
    except FlowvoError:
        raise
    except (ValueError, TypeError, KeyError, IndexError) as error:
        raise FlowvoError(f"malformed calibration file: {error}", path) from None


def _looks_like_kitti(text: str) -> bool:
    first = next((line for line in text.splitlines() if line.strip()), "")
    return first.split(":", 1)[0].strip() in ("P0", "P1", "P2", "P3", "Tr", "K0")


def _kitti(path: Path) -> CameraFile:
    from flowvo.kitti.calib import read_calibration

    calibration = read_calibration(path)
    intrinsics = CameraIntrinsics.from_matrix(calibration.K0)
    check_intrinsics(intrinsics, None, str(path))
    return CameraFile(intrinsics, calibration.distortion, calibration.camera_height_m, None, "kitti calib.txt",
                      calibration.camera_pitch_deg, calibration.camera_roll_deg, calibration.readout_ms)


def _opencv_storage(text: str, path: Path) -> CameraFile:
    import cv2

    try:
        storage = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    except (cv2.error, SystemError) as error:  # OpenCV's Python binding raises SystemError for some parse errors
        line, reason = _opencv_reason(error)
        raise FlowvoError(f"not a readable OpenCV FileStorage file ({reason}; cut short or malformed?)", path,
                          line) from None
    try:
        K = _storage_matrix(storage.getNode("camera_matrix"), "camera_matrix", path)
        if K is None:
            raise FlowvoError("OpenCV FileStorage file without camera_matrix", path)
        if K.shape != (3, 3):
            raise FlowvoError(f"camera_matrix must be 3x3, got {K.shape[0]}x{K.shape[1]}", path)
        D = _storage_matrix(storage.getNode("distortion_coefficients"), "distortion_coefficients", path)
        coefficients = () if D is None else tuple(D.ravel())
        model_node = storage.getNode("distortion_model")
        model = None
        if not model_node.empty():
            if not model_node.isString():
                raise FlowvoError("distortion_model must be a name such as plumb_bob", path)
            model = model_node.string()
        size = _size(_storage_number(storage, "image_width", path), _storage_number(storage, "image_height", path),
                     path)
        height = _storage_number(storage, "camera_height_m", path)
    finally:
        storage.release()
    return _camera_file(CameraIntrinsics.from_matrix(K), model, coefficients, height, size, "OpenCV FileStorage", path)


def _opencv_reason(error: BaseException) -> tuple[int | None, str]:
    """The line (when OpenCV says) and the reason of an OpenCV parse error, from the error or its cause."""
    import re

    cause = error.__cause__ or error.__context__ or error
    text = str(cause).strip().splitlines()[-1] if str(cause).strip() else type(error).__name__
    found = re.search(r"in function '\((\d+)\): (.*)'$", text)
    if found:
        return int(found.group(1)), found.group(2).strip()
    return None, re.sub(r"^OpenCV\([^)]*\) \S+: error: \([^)]*\) ", "", text)


def _storage_matrix(node: Any, name: str, path: Path) -> np.ndarray | None:
    """The matrix of a FileStorage node (None when absent), its ``rows`` x ``cols`` checked against the
    numbers its ``data`` holds (OpenCV asserts on a mismatch)."""
    import cv2

    if node.empty():
        return None
    if node.isSeq():  # a plain list of numbers
        items = [node.at(i) for i in range(node.size())]
        if not all(item.isInt() or item.isReal() for item in items):
            raise FlowvoError(f"{name} must be a list of numbers", path)
        return np.array([[item.real() for item in items]], dtype=np.float64)
    if node.isMap():
        rows, cols, data = node.getNode("rows"), node.getNode("cols"), node.getNode("data")
        if not (rows.isInt() and cols.isInt() and data.isSeq()):
            raise FlowvoError(f"{name} must be an opencv-matrix with rows, cols and a data list", path)
        expected = int(rows.real()) * int(cols.real())
        if data.size() != expected:
            raise FlowvoError(f"{name} says rows {int(rows.real())}, cols {int(cols.real())} ({expected} numbers) but "
                              f"its data holds {data.size()}", path)
    try:
        matrix = node.mat()
    except cv2.error as error:
        raise FlowvoError(f"{name} is not a readable matrix ({_opencv_reason(error)[1]})", path) from None
    if matrix is None:
        raise FlowvoError(f"{name} is not a matrix (expected an opencv-matrix with rows, cols and data)", path)
    matrix = np.asarray(matrix, dtype=np.float64)
    return matrix.reshape(matrix.shape[0], -1) if matrix.ndim >= 2 else matrix.reshape(1, -1)


def _storage_number(storage: Any, name: str, path: Path) -> float | None:
    """The number at ``name`` (None when absent); a one-line error for text or a list there."""
    node = storage.getNode(name)
    if node.empty():
        return None
    if not (node.isInt() or node.isReal()):
        shown = repr(node.string()) if node.isString() else "a list or map"
        raise FlowvoError(f"{name} must be a number, got {shown}", path)
    return float(node.real())


def _yaml(text: str, path: Path) -> CameraFile:
    import yaml

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        raise FlowvoError(f"not a calibration file: YAML error {getattr(error, 'problem', '') or ''}".rstrip(),
                          path, mark.line + 1 if mark else None) from None
    if not isinstance(data, dict):
        raise FlowvoError("not a calibration file: expected a KITTI calib.txt, an OpenCV FileStorage, a ROS "
                          "camera_calibration or a Kalibr camchain YAML", path)
    if "camera_matrix" in data:  # ROS camera_calibration
        K = np.asarray(_matrix_data(data["camera_matrix"], "camera_matrix", path), dtype=np.float64)
        if K.size != 9:
            raise FlowvoError(f"camera_matrix must have 9 numbers, got {K.size}", path)
        coefficients = data.get("distortion_coefficients") or ()
        if isinstance(coefficients, dict):
            coefficients = _matrix_data(coefficients, "distortion_coefficients", path)
        size = _size(_yaml_number(data, "image_width", path), _yaml_number(data, "image_height", path), path)
        return _camera_file(CameraIntrinsics.from_matrix(K.reshape(3, 3)), data.get("distortion_model"),
                            tuple(coefficients), data.get("camera_height_m"), size, "ROS camera_calibration", path)
    cameras = sorted(key for key in data if isinstance(key, str) and key.startswith("cam") and key[3:].isdigit())
    if cameras:  # Kalibr camchain: the first camera
        camera = data[cameras[0]]
        if not isinstance(camera, dict) or "intrinsics" not in camera:
            raise FlowvoError(f"Kalibr camchain: {cameras[0]} has no intrinsics", path)
        model = str(camera.get("camera_model", "pinhole"))
        if model != "pinhole":
            raise FlowvoError(f"Kalibr camera_model {model!r} is not supported (only pinhole)", path)
        values = _numbers(camera["intrinsics"], "intrinsics", path)
        if len(values) != 4:
            raise FlowvoError(f"Kalibr intrinsics must be [fu, fv, pu, pv], got {len(values)} numbers", path)
        resolution = camera.get("resolution")
        if resolution is None:
            size = None
        else:
            width_height = _numbers(resolution, "Kalibr resolution", path)
            if len(width_height) != 2:
                raise FlowvoError(f"Kalibr resolution must be [width, height], got {len(width_height)} numbers", path)
            size = _size(width_height[0], width_height[1], path)
        return _camera_file(CameraIntrinsics(*values), camera.get("distortion_model", "none"),
                            tuple(camera.get("distortion_coeffs") or ()), camera.get("camera_height_m",
                                                                                      data.get("camera_height_m")),
                            size, "Kalibr camchain", path)
    raise FlowvoError("not a calibration file: no camera_matrix (OpenCV, ROS) and no cam0 (Kalibr)", path)


def _matrix_data(node: Any, name: str, path: Path) -> list[float]:
    if not isinstance(node, dict) or "data" not in node:
        raise FlowvoError(f"{name} has no 'data' list", path)
    return _numbers(node["data"], name, path)


def _numbers(values: Any, name: str, path: Path) -> list[float]:
    if not isinstance(values, list | tuple) or not all(isinstance(v, int | float) and not isinstance(v, bool)
                                                       for v in values):
        raise FlowvoError(f"{name} must be a list of numbers", path)
    return [float(v) for v in values]


def _yaml_number(data: dict, name: str, path: Path) -> float | None:
    value = data.get(name)
    return None if value is None else _number(value, name, path)


def _size(width: float | None, height: float | None, path: Path) -> tuple[int, int] | None:
    """(height, width) when both are given (positive whole numbers of pixels), None when neither is (OpenCV
    writes 0 for unknown); a one-line error otherwise."""
    if width in (None, 0) and height in (None, 0):
        return None
    if width is None or height is None:
        raise FlowvoError(f"gives the image {'width' if height is None else 'height'} but not its "
                          f"{'height' if height is None else 'width'}", path)
    if not (math.isfinite(width) and math.isfinite(height) and width >= 1 and height >= 1 and width.is_integer()
            and height.is_integer() and max(width, height) <= MAX_IMAGE_SIDE_PX):
        raise FlowvoError(f"image size must be whole numbers of pixels in [1, {MAX_IMAGE_SIDE_PX}], got "
                          f"{width:g}x{height:g}", path)
    return int(height), int(width)


def _camera_file(intrinsics: CameraIntrinsics, model: Any, coefficients: tuple, height: Any,
                 size: tuple[int, int] | None, kind: str, path: Path) -> CameraFile:
    check_intrinsics(intrinsics, None, str(path))
    coefficients = tuple(_numbers(list(coefficients), "distortion coefficients", path))
    if model is None:  # OpenCV leaves the model to the count: 4 or 5 plumb-bob, 8 rational
        model = "rational_polynomial" if len(coefficients) == 8 else "plumb_bob"
    try:
        distortion = LensDistortion(str(model), coefficients)
    except FlowvoError as error:
        raise FlowvoError(str(error), path) from None
    height_m = None if height is None else check_camera_height(_number(height, "camera_height_m", path), str(path))
    return CameraFile(intrinsics, distortion, height_m, size, kind)


def _number(value: Any, name: str, path: Path) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FlowvoError(f"{name} must be a number, got {value!r}", path)
    return float(value)


def format_ros_calibration(intrinsics: CameraIntrinsics, distortion: LensDistortion, image_size_hw: tuple[int, int],
                           camera_name: str = "camera", height_m: float | None = None,
                           rms_px: float | None = None) -> str:
    """A ROS camera_calibration YAML (what ``camera_info_manager`` and ``flowvo run --calib`` read), with
    flowvo's optional ``camera_height_m`` and the calibration's RMS reprojection error as extra keys."""
    import yaml

    h, w = image_size_hw
    K = intrinsics.K
    P = np.c_[K, np.zeros(3)]
    model = "plumb_bob" if distortion.is_none else distortion.model
    data: dict[str, Any] = {
        "image_width": int(w), "image_height": int(h), "camera_name": camera_name,
        "camera_matrix": {"rows": 3, "cols": 3, "data": [float(v) for v in K.ravel()]},
        "distortion_model": model,
        "distortion_coefficients": {"rows": 1, "cols": len(distortion.coefficients) or 5,
                                    "data": list(distortion.coefficients) or [0.0] * 5},
        "rectification_matrix": {"rows": 3, "cols": 3, "data": [float(v) for v in np.eye(3).ravel()]},
        "projection_matrix": {"rows": 3, "cols": 4, "data": [float(v) for v in P.ravel()]},
    }
    if height_m is not None:
        data["camera_height_m"] = float(height_m)
    if rms_px is not None:
        data["rms_reprojection_error_px"] = float(rms_px)
    return yaml.safe_dump(data, sort_keys=False)
