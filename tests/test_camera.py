"""The camera: distortion models, calibration files of every kind, and what overrides what."""

import cv2
import numpy as np
import pytest

from flowvo.calibration.files import format_ros_calibration, read_camera_file
from flowvo.camera import (
    KITTI_CAMERA_HEIGHT_M,
    Camera,
    CameraIntrinsics,
    LensDistortion,
    check_camera_height,
    distort_points,
    undistort_points,
    undistortion_maps,
)
from flowvo.camera_options import drive_camera, given_camera
from flowvo.errors import FlowvoError

INTRINSICS = CameraIntrinsics(500.0, 502.0, 320.5, 240.5)
BARREL = LensDistortion("plumb_bob", (-0.25, 0.05, 0.001, -0.002))


@pytest.mark.parametrize("distortion", [BARREL, LensDistortion("rational_polynomial", (-0.2, 0.05, 0.001, 0.0, 0.01,
                                                                                      0.01, 0.002, 0.001)),
                                        LensDistortion("equidistant", (0.05, -0.01, 0.002, 0.0))])
def test_undistort_inverts_distort_for_every_model(distortion):
    ideal = np.random.default_rng(0).uniform([40, 30], [600, 450], (500, 2))
    distorted = distort_points(ideal, INTRINSICS.K, distortion)
    assert np.abs(distorted - ideal).max() > 5  # the lens moves points by pixels
    np.testing.assert_allclose(undistort_points(distorted, INTRINSICS.K, distortion), ideal, atol=1e-3)


def test_undistortion_maps_turn_a_lens_image_into_the_pinhole_image():
    ys, xs = np.mgrid[0:480, 0:640].astype(np.float32)
    ideal = ((np.sin(xs / 9.0) + np.cos(ys / 7.0)) * 60 + 128).astype(np.uint8)  # a smooth pattern
    ideal_of_distorted = undistort_points(np.stack([xs.ravel(), ys.ravel()], 1), INTRINSICS.K, BARREL)
    through_lens = cv2.remap(ideal, *ideal_of_distorted.reshape(480, 640, 2).transpose(2, 0, 1), cv2.INTER_LINEAR)
    back = cv2.remap(through_lens, *undistortion_maps((480, 640), INTRINSICS.K, BARREL), cv2.INTER_LINEAR)
    centre = (slice(120, 360), slice(160, 480))  # away from the border the lens pushed out of the frame
    assert np.abs(back[centre].astype(int) - ideal[centre]).mean() < 2.0


@pytest.mark.parametrize(("model", "coefficients", "message"), [
    ("plumb_bob", (0.1, 0.2, 0.3), "takes 4 or 5 coefficients, got 3"),
    ("equidistant", (0.1,) * 5, "takes 4 coefficients, got 5"),
    ("rational_polynomial", (0.1,) * 5, "takes 8 coefficients"),
    ("plumb_bob", (float("nan"), 0, 0, 0), "must be finite"),
    ("mei", (0.1,) * 4, "unknown distortion model 'mei'"),
])
def test_bad_distortion_is_one_clear_error(model, coefficients, message):
    with pytest.raises(FlowvoError, match=message):
        LensDistortion(model, coefficients)


def test_distortion_names_of_ros_and_kalibr_are_understood_and_zeros_are_no_distortion():
    assert LensDistortion("radtan", (0.1, 0, 0, 0)).model == "plumb_bob"
    assert LensDistortion("fisheye", (0.1, 0, 0, 0)).model == "equidistant"
    assert LensDistortion("plumb_bob", (0.0,) * 5).is_none


@pytest.mark.parametrize("height", [0.0, -1.0, float("nan"), float("inf"), 11.0])
def test_implausible_camera_heights_are_refused(height):
    with pytest.raises(FlowvoError, match="camera height"):
        check_camera_height(height)


def _opencv_file(path, suffix):
    name = str(path / f"cam{suffix}")
    storage = cv2.FileStorage(name, cv2.FILE_STORAGE_WRITE)
    storage.write("image_width", 640)
    storage.write("image_height", 480)
    storage.write("camera_matrix", INTRINSICS.K)
    storage.write("distortion_coefficients", np.array([BARREL.coefficients]))
    storage.write("camera_height_m", 1.3)
    storage.release()
    return name


@pytest.mark.parametrize("suffix", [".yaml", ".xml"])
def test_opencv_filestorage_yaml_and_xml(tmp_path, suffix):
    camera = read_camera_file(_opencv_file(tmp_path, suffix))
    assert camera.intrinsics == INTRINSICS and camera.distortion == BARREL and camera.height_m == 1.3
    assert camera.image_size_hw == (480, 640) and camera.kind == "OpenCV FileStorage"


def test_ros_camera_calibration_yaml_round_trips(tmp_path):
    path = tmp_path / "ros.yaml"
    path.write_text(format_ros_calibration(INTRINSICS, BARREL, (480, 640), height_m=1.42, rms_px=0.2))
    camera = read_camera_file(path)
    assert (camera.intrinsics, camera.distortion, camera.height_m) == (INTRINSICS, BARREL, 1.42)
    assert camera.kind == "ROS camera_calibration"


def test_kalibr_camchain_first_camera(tmp_path):
    path = tmp_path / "camchain.yaml"
    path.write_text("cam0:\n  camera_model: pinhole\n  intrinsics: [500.0, 502.0, 320.5, 240.5]\n"
                    "  distortion_model: equidistant\n  distortion_coeffs: [0.05, -0.01, 0.002, 0.0]\n"
                    "  resolution: [640, 480]\ncam1:\n  camera_model: pinhole\n  intrinsics: [1, 1, 1, 1]\n")
    camera = read_camera_file(path)
    assert camera.intrinsics == INTRINSICS and camera.distortion.model == "equidistant"
    assert camera.image_size_hw == (480, 640) and camera.height_m is None


def test_kitti_calib_with_flowvo_camera_lines(tmp_path):
    path = tmp_path / "calib.txt"
    path.write_text("P0: 500 0 320.5 0 0 502 240.5 0 0 0 1 0\ndistortion: -0.25 0.05 0.001 -0.002\n"
                    "camera_height_m: 1.2\ncamera_pitch_deg: 7.5\ncamera_roll_deg: -4.25\n")
    camera = read_camera_file(path)
    assert camera.intrinsics == INTRINSICS and camera.distortion == BARREL and camera.height_m == 1.2
    assert (camera.pitch_deg, camera.roll_deg) == (7.5, -4.25)


def read_calibration_text(tmp_path, text):
    from flowvo.kitti.calib import read_calibration

    (tmp_path / "plain.txt").write_text(text)
    return read_calibration(tmp_path / "plain.txt")


def test_a_pitch_and_roll_in_calib_txt_survive_writing_and_reading(tmp_path):
    from flowvo.kitti.calib import Calibration, format_calibration, read_calibration

    calibration = Calibration({"P0": np.hstack([INTRINSICS.K, np.zeros((3, 1))])}, BARREL, 1.2, -3.25, 6.5)
    (tmp_path / "calib.txt").write_text(format_calibration(calibration))
    back = read_calibration(tmp_path / "calib.txt")
    assert (back.distortion, back.camera_height_m, back.camera_pitch_deg, back.camera_roll_deg) == \
        (BARREL, 1.2, -3.25, 6.5)
    plain = read_calibration_text(tmp_path, "P0: 500 0 320.5 0 0 502 240.5 0 0 0 1 0\n")
    assert plain.camera_pitch_deg is None and plain.camera_roll_deg is None


@pytest.mark.parametrize(("line", "message"), [
    ("camera_pitch_deg: 45", "camera pitch must be a finite number of degrees in \\[-30, 30\\]"),
    ("camera_pitch_deg: nan", "camera pitch must be a finite number"),
    ("camera_pitch_deg: 1 2", "camera_pitch_deg: expected one number \\(degrees\\)"),
    ("camera_pitch_deg: down", "camera_pitch_deg: expected numbers, found text"),
    ("camera_roll_deg: -16", "camera roll must be a finite number of degrees in \\[-15, 15\\]"),
    ("camera_roll_deg: inf", "camera roll must be a finite number"),
    ("camera_roll_deg: 1 2", "camera_roll_deg: expected one number \\(degrees\\)"),
])
def test_a_bad_pitch_line_is_a_one_line_error_naming_the_file_and_line(tmp_path, line, message):
    with pytest.raises(FlowvoError, match=message) as error:
        read_calibration_text(tmp_path, f"P0: 500 0 320.5 0 0 502 240.5 0 0 0 1 0\n{line}\n")
    assert "plain.txt:2" in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize(("text", "message"), [
    ("just: text\n", "no camera_matrix"),
    ("camera_matrix:\n  data: [1, 2]\n", "must have 9 numbers"),
    ("camera_matrix:\n  data: [500, 0, 320, 0, 500, 240, 0, 0, 1]\ndistortion_coefficients:\n  data: [1, 2, 3]\n",
     "takes 4 or 5 coefficients, got 3"),
    ("camera_matrix:\n  data: [0, 0, 320, 0, 500, 240, 0, 0, 1]\n", "focal lengths in \\[1, 100000\\] px"),
    ("camera_matrix:\n  data: [500, 0, 320, 0, 500, 240, 0, 0, 1]\ncamera_height_m: -2\n", "camera height"),
    ("cam0:\n  camera_model: omni\n  intrinsics: [1, 1, 1, 1]\n", "not supported"),
    ("[unclosed\n", "YAML error"),
])
def test_bad_calibration_files_are_one_line_errors_naming_the_file(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(FlowvoError, match=message) as error:
        read_camera_file(path)
    assert "bad.yaml" in str(error.value) and "\n" not in str(error.value)


def test_flags_override_the_drive_camera_and_the_height_defaults_to_kitti():
    drive = Camera(INTRINSICS, BARREL, None, "kitti")
    kept = drive_camera(given_camera(None, None, None, None, None), drive, (480, 640), "d")
    assert kept == drive and kept.camera_height_m == KITTI_CAMERA_HEIGHT_M and not kept.record()["camera_height_given"]
    height_only = drive_camera(given_camera(None, None, None, None, None, camera_height_m=1.3), drive, (480, 640), "d")
    assert height_only.height_m == 1.3 and height_only.distortion == BARREL and height_only.source == "kitti"
    flags = drive_camera(given_camera(None, 400.0, 400.0, 300.0, 200.0, distortion=(0.1, 0.0, 0.0, 0.0)), drive,
                         (480, 640), "d")
    assert flags.intrinsics.fx == 400.0 and flags.distortion.coefficients == (0.1, 0.0, 0.0, 0.0)
    assert flags.source == "flags"


def test_the_pitch_comes_from_the_flag_else_the_calibration_else_level():
    drive = Camera(INTRINSICS, BARREL, None, "kitti", pitch_deg=6.0)
    assert drive_camera(given_camera(None, None, None, None, None), drive, (480, 640), "d").pitch_deg == 6.0
    told = drive_camera(given_camera(None, None, None, None, None, camera_pitch_deg=0.0), drive, (480, 640), "d")
    assert told.pitch_deg == 0.0 and told.record()["camera_pitch_deg"] == 0.0
    assert drive_camera(given_camera(None, 400.0, 400.0, 300.0, 200.0), None, (480, 640), "d").pitch_deg == 0.0
    assert drive.scaled(0.5, 0.5).pitch_deg == 6.0


def test_the_roll_comes_from_the_flag_else_the_calibration_else_level_and_turns_the_road_levelling():
    drive = Camera(INTRINSICS, BARREL, None, "kitti", pitch_deg=6.0, roll_deg=-5.0)
    kept = drive_camera(given_camera(None, None, None, None, None), drive, (480, 640), "d")
    assert (kept.pitch_deg, kept.roll_deg, kept.record()["camera_roll_deg"]) == (6.0, -5.0, -5.0)
    told = drive_camera(given_camera(None, None, None, None, None, camera_roll_deg=0.0), drive, (480, 640), "d")
    assert (told.pitch_deg, told.roll_deg) == (6.0, 0.0) and not told.is_level
    level = drive_camera(given_camera(None, None, None, None, None, camera_pitch_deg=0.0, camera_roll_deg=0.0), drive,
                         (480, 640), "d")
    assert level.is_level and drive.scaled(0.5, 0.5).roll_deg == -5.0
    # the road's downward normal, seen by the camera, levelled back to the level camera's down axis
    road_normal_in_camera = np.array([np.sin(np.radians(-5.0)) * np.cos(np.radians(6.0)),
                                      np.cos(np.radians(-5.0)) * np.cos(np.radians(6.0)), np.sin(np.radians(6.0))])
    np.testing.assert_allclose(drive.road_levelling @ road_normal_in_camera, [0.0, 1.0, 0.0], atol=1e-12)


def test_the_readout_time_comes_from_the_flag_else_the_calibration_else_a_global_shutter(tmp_path):
    drive = Camera(INTRINSICS, BARREL, None, "kitti", readout_ms=25.0)
    assert drive_camera(given_camera(None, None, None, None, None), drive, (480, 640), "d").readout_ms == 25.0
    told = drive_camera(given_camera(None, None, None, None, None, readout_ms=0.0), drive, (480, 640), "d")
    assert told.readout_ms == 0.0 and told.record()["readout_ms"] == 0.0
    assert drive_camera(given_camera(None, 400.0, 400.0, 300.0, 200.0), None, (480, 640), "d").readout_ms == 0.0
    calib = tmp_path / "calib.txt"
    calib.write_text("P0: 400 0 320 0 0 400 240 0 0 0 1 0\nreadout_ms: 33.3\n")
    from_file = drive_camera(given_camera(str(calib), None, None, None, None), None, (480, 640), "d")
    assert from_file.readout_ms == 33.3
    calib.write_text("P0: 400 0 320 0 0 400 240 0 0 0 1 0\nreadout_ms: -2\n")
    with pytest.raises(FlowvoError, match=r"calib.txt:2: readout time must be a finite number of milliseconds"):
        given_camera(str(calib), None, None, None, None)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"fx": 500.0}, "missing --fy --cx --cy"),
    ({"distortion_model": "equidistant"}, "--distortion-model needs --dist"),
    ({"distortion": (0.1, 0.2)}, "takes 4 or 5 coefficients, got 2"),
    ({"camera_height_m": -1.0}, "camera height"),
    ({"camera_pitch_deg": 31.0}, "camera pitch"),
    ({"camera_roll_deg": -15.5}, "--camera-roll: camera roll must be"),
    ({"readout_ms": float("nan")}, "--readout-ms: readout time must be"),
])
def test_bad_camera_flags(kwargs, message):
    arguments = {"calib": None, "fx": None, "fy": None, "cx": None, "cy": None} | kwargs
    with pytest.raises(FlowvoError, match=message):
        given_camera(**arguments)


def test_principal_point_outside_the_frame_is_refused_for_any_source():
    with pytest.raises(FlowvoError, match="lies outside the 640x480 image"):
        drive_camera(given_camera(None, 500.0, 500.0, 700.0, 200.0), None, (480, 640), "drive")
