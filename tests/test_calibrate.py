"""flowvo calibrate: known cameras recovered from rendered boards, refusals of views that cannot determine
a camera, and the file it writes read back by ``flowvo run --calib``'s reader."""

import os
from pathlib import Path

import cv2
import numpy as np
import pytest
from calibration_boards import (
    TrueCamera,
    charuco_texture,
    checkerboard_texture,
    render_view,
    varied_poses,
    viewing_rays,
)

from flowvo.calibration import board as board_module
from flowvo.calibration import calibrate as calibrate_module
from flowvo.calibration.board import Board
from flowvo.calibration.calibrate import calibrate, coverage_fraction, spread_views, tilt_spread_deg
from flowvo.calibration.files import read_camera_file
from flowvo.calibration.images import open_calibration_images
from flowvo.camera import CameraIntrinsics, LensDistortion
from flowvo.cli import main
from flowvo.errors import FlowvoError

SHARED = Path(__file__).resolve().parents[1].parent / "shared"

SIZE_HW = (480, 640)
ROWS, COLS, SQUARE_M = 6, 9, 0.03  # checkerboard inner corners
SQUARE_PX = 40  # texture resolution: ~1.5 texture pixels per rendered (supersampled) pixel
PLUMB_BOB = TrueCamera(CameraIntrinsics(500.0, 500.0, 334.0, 226.0),
                       LensDistortion("plumb_bob", (-0.25, 0.05, 0.0, 0.0, 0.0)), SIZE_HW)
FISHEYE = TrueCamera(CameraIntrinsics(350.0, 350.0, 326.0, 236.0),
                     LensDistortion("equidistant", (0.05, -0.02, 0.0, 0.0)), SIZE_HW)
CHECKERBOARD = Board("checkerboard", ROWS, COLS, SQUARE_M)
CHECKERBOARD_SIZE_M = ((COLS + 3) * SQUARE_M, (ROWS + 3) * SQUARE_M)  # with its white margin


@pytest.fixture(scope="module")
def plumb_bob_rays():
    return viewing_rays(PLUMB_BOB)


def render(rays, texture, square_m, poses):
    return [render_view(rays, texture, SQUARE_PX / square_m, angles, t) for angles, t in poses]


def labelled(images, prefix="view"):
    return [(f"{prefix} {i}", image) for i, image in enumerate(images)]


@pytest.fixture(scope="module")
def checkerboard_views(plumb_bob_rays):
    """15 views of the checkerboard through the plumb-bob camera, from varied poses."""
    poses = varied_poses(15, PLUMB_BOB, CHECKERBOARD_SIZE_M)
    return render(plumb_bob_rays, checkerboard_texture(ROWS, COLS, SQUARE_PX), SQUARE_M, poses)


@pytest.fixture(scope="module")
def checkerboard_result(checkerboard_views):
    return calibrate(labelled(checkerboard_views), CHECKERBOARD)


@pytest.fixture(scope="module")
def board_folder(checkerboard_views, tmp_path_factory):
    folder = tmp_path_factory.mktemp("views")
    for i, image in enumerate(checkerboard_views):
        cv2.imwrite(str(folder / f"view_{i:02d}.png"), image)
    (folder / "notes.txt").write_text("not an image: ignored\n")
    return folder


def assert_recovers(result, camera: TrueCamera, k1_tolerance: float = 0.02):
    found, true = result.intrinsics, camera.intrinsics
    assert found.fx == pytest.approx(true.fx, rel=0.01) and found.fy == pytest.approx(true.fy, rel=0.01)
    assert found.cx == pytest.approx(true.cx, abs=3.0) and found.cy == pytest.approx(true.cy, abs=3.0)
    assert result.distortion.model == camera.distortion.model
    assert result.distortion.coefficients[0] == pytest.approx(camera.distortion.coefficients[0], abs=k1_tolerance)
    assert result.image_size_hw == SIZE_HW


def test_checkerboard_recovers_known_intrinsics_and_plumb_bob_distortion(checkerboard_result):
    result = checkerboard_result
    assert_recovers(result, PLUMB_BOB)
    assert len(result.distortion.coefficients) == 5
    assert result.rms_px < 0.2 and max(result.view_rms_px) < 0.3  # rendered corners: a fraction of a pixel
    assert result.images_seen == result.views_found == result.views_used == 15
    assert result.view_labels[0] == "view 0" and len(result.view_rms_px) == 15
    assert result.tilt_spread_deg > 40 and result.coverage > 0.4
    assert result.warnings == ()


def test_a_large_reprojection_error_is_a_warning_not_a_refusal(checkerboard_views, monkeypatch):
    monkeypatch.setattr(calibrate_module, "RMS_WARNING_PX", 0.01)
    result = calibrate(labelled(checkerboard_views), CHECKERBOARD)
    assert len(result.warnings) == 1 and "RMS reprojection error" in result.warnings[0]


def test_rational_model_gives_eight_coefficients_and_the_same_camera(checkerboard_views):
    result = calibrate(labelled(checkerboard_views), CHECKERBOARD, "rational_polynomial")
    assert result.distortion.model == "rational_polynomial" and len(result.distortion.coefficients) == 8
    assert result.intrinsics.fx == pytest.approx(PLUMB_BOB.intrinsics.fx, rel=0.01) and result.rms_px < 0.2


def test_large_frames_are_searched_downscaled_and_refined_at_full_resolution(checkerboard_views, monkeypatch,
                                                                            checkerboard_result):
    monkeypatch.setattr(board_module, "DETECT_MAX_SIDE_PX", 400)  # the 640x480 views are searched at 400x300
    result = calibrate(labelled(checkerboard_views), CHECKERBOARD)
    assert result.views_found == 15
    assert result.rms_px == pytest.approx(checkerboard_result.rms_px, rel=0.05)  # the same sub-pixel corners
    assert_recovers(result, PLUMB_BOB)


def test_equidistant_fisheye_is_recovered():
    poses = varied_poses(12, FISHEYE, CHECKERBOARD_SIZE_M, seed=1, distance_m=(0.3, 0.55))
    images = render(viewing_rays(FISHEYE), checkerboard_texture(ROWS, COLS, SQUARE_PX), SQUARE_M, poses)
    result = calibrate(labelled(images), CHECKERBOARD, "equidistant")
    assert_recovers(result, FISHEYE)
    assert len(result.distortion.coefficients) == 4 and result.rms_px < 0.3


CHARUCO_ROWS, CHARUCO_COLS, CHARUCO_SQUARE_M, CHARUCO_MARKER_M = 7, 9, 0.03, 0.022


@pytest.fixture(scope="module")
def charuco_views(plumb_bob_rays):
    """12 views of a ChArUco board through the plumb-bob camera."""
    rows, cols, square_m = CHARUCO_ROWS, CHARUCO_COLS, CHARUCO_SQUARE_M
    opencv_board = cv2.aruco.CharucoBoard((cols, rows), square_m, CHARUCO_MARKER_M,
                                          cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50))
    poses = varied_poses(12, PLUMB_BOB, ((cols + 2) * square_m, (rows + 2) * square_m), seed=2)
    return render(plumb_bob_rays, charuco_texture(opencv_board, SQUARE_PX), square_m, poses)


def charuco_board(scale: float = 1.0) -> Board:
    return Board("charuco", CHARUCO_ROWS, CHARUCO_COLS, CHARUCO_SQUARE_M * scale, CHARUCO_MARKER_M * scale)


def test_charuco_board_is_recovered(charuco_views):
    result = calibrate(labelled(charuco_views), charuco_board())
    assert_recovers(result, PLUMB_BOB)
    assert result.views_used >= 10 and result.rms_px < 0.3


@pytest.mark.parametrize("scale", [1e7, 1e-5])
def test_a_charuco_board_in_any_unit_is_found_and_gives_the_same_camera(charuco_views, scale):
    """OpenCV's ChArUco detector has tolerances in the board's unit: a board in kilometres was never found. The same
    camera within 1e-6 of each value (2e-4 px): the solver's sums run in OpenCV's thread pool, and one clean-clone CI
    run in five read cy 7e-9 apart in kilometres."""
    reference = calibrate(labelled(charuco_views), charuco_board())
    result = calibrate(labelled(charuco_views), charuco_board(scale))
    assert result.views_found == reference.views_found
    assert result.intrinsics.fx == pytest.approx(reference.intrinsics.fx, rel=1e-6)
    assert result.intrinsics.cy == pytest.approx(reference.intrinsics.cy, rel=1e-6)


def test_cli_writes_the_file_run_reads_back_identically(board_folder, checkerboard_result, tmp_path, capsys,
                                                         monkeypatch):
    results = []

    def recorded(*args, **kwargs):
        results.append(calibrate(*args, **kwargs))
        return results[-1]

    monkeypatch.setattr(calibrate_module, "calibrate", recorded)
    out = tmp_path / "calib.yaml"
    args = ["calibrate", str(board_folder), "--rows", str(ROWS), "--cols", str(COLS), "--square", str(SQUARE_M),
            "--camera-height", "1.3", "--out", str(out), "-q"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "found in 15 of 15 images; 15 distinct views used" in printed and "RMS reprojection error" in printed
    assert f"flowvo run --video DRIVE.mp4 --calib {out}" in printed
    camera, result = read_camera_file(out), results[0]
    assert camera.intrinsics == result.intrinsics and camera.distortion == result.distortion  # bit for bit
    assert camera.image_size_hw == SIZE_HW and camera.height_m == 1.3
    assert f"fx {camera.intrinsics.fx:.2f}" in printed
    # lossless PNGs: the same views as the arrays, the same camera (up to OpenCV's threaded sums)
    assert camera.intrinsics.fx == pytest.approx(checkerboard_result.intrinsics.fx, rel=1e-9)

    assert main(args) == 2  # an earlier file is not overwritten silently
    assert "pass --force" in capsys.readouterr().err
    refused = [*args, "--force", "--rows", "5"]  # a board that is not there
    assert main(refused) == 2 and read_camera_file(out) == camera  # the earlier file stays
    assert main([*args, "--force"]) == 0


def test_image_names_that_are_not_utf8_are_read_and_printed(board_folder, tmp_path, capsys):
    folder = tmp_path / os.fsdecode(b"views \xff")
    folder.mkdir()
    for i, file in enumerate(sorted(board_folder.glob("*.png"))):
        (folder / os.fsdecode(b"\xfe view %02d.png" % i)).write_bytes(file.read_bytes())
    board = ["calibrate", str(folder), "--rows", str(ROWS), "--cols", str(COLS), "-q"]
    assert main([*board, "--out", str(folder / os.fsdecode(b"\xfd.yaml"))]) == 2  # outputs get UTF-8 names
    assert "not UTF-8" in capsys.readouterr().err
    out = tmp_path / "cam.yaml"
    assert main([*board, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "found in 15 of 15 images" in printed and "views \\xff/\\xfe view" in printed  # the worst view
    assert read_camera_file(out).image_size_hw == SIZE_HW


def write_video(path: Path, images: list[np.ndarray]) -> None:
    """A lossless FFV1 video of grey ``images``."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), 10, (images[0].shape[1], images[0].shape[0]))
    assert writer.isOpened()
    for image in images:
        writer.write(cv2.cvtColor(image, cv2.COLOR_GRAY2BGR))
    writer.release()


def test_a_video_of_the_board_calibrates(checkerboard_views, tmp_path):
    path = tmp_path / "board.avi"
    write_video(path, checkerboard_views)
    images = open_calibration_images(path, every=1)
    assert images.count == 15
    result = calibrate(images.frames(), CHECKERBOARD)
    assert_recovers(result, PLUMB_BOB)
    assert result.view_labels[3] == f"{path} frame 3"
    assert open_calibration_images(path).count == 1  # by default every 15th frame of a video


def refusal(args: list[str], capsys) -> str:
    assert main(["calibrate", *args, "--rows", str(ROWS), "--cols", str(COLS), "-q"]) == 2
    message = capsys.readouterr().err
    assert message.count("\n") == 1  # one line
    return message


def test_board_in_too_few_images_is_refused(checkerboard_views, tmp_path, capsys):
    for i, image in enumerate(checkerboard_views[:3] + [np.full(SIZE_HW, 128, np.uint8)] * 5):
        cv2.imwrite(str(tmp_path / f"{i}.png"), image)
    message = refusal([str(tmp_path), "--out", str(tmp_path / "c.yaml")], capsys)
    assert "found in only 3 of 8 images" in message and "at least 8 views" in message
    assert not (tmp_path / "c.yaml").exists()


def test_images_without_the_board_are_refused(tmp_path, capsys):
    noise = np.random.default_rng(0).integers(0, 256, (2, 240, 320), dtype=np.uint8)
    for i, image in enumerate([*noise, np.zeros((240, 320), np.uint8), np.full((240, 320), 255, np.uint8)]):
        cv2.imwrite(str(tmp_path / f"{i}.jpg"), image)
    message = refusal([str(tmp_path), "--out", str(tmp_path / "c.yaml")], capsys)
    assert "was not found in any of the 4 images" in message and "--rows" in message


def test_a_video_without_the_board_is_refused(tmp_path, capsys):
    write_video(tmp_path / "drive.avi", [np.zeros((48, 80), np.uint8)] * 3)
    message = refusal([str(tmp_path / "drive.avi"), "--out", str(tmp_path / "c.yaml"), "--every", "1"], capsys)
    assert "not found in any of the 3 images" in message


@pytest.mark.parametrize("setup, expected", [
    (lambda folder: (folder / "a.txt").write_text("x"), "no images (.png"),
    (lambda folder: (folder / "a.png").write_bytes(b"not a png"), "a.png: is not a readable image"),
    (lambda folder: (folder / "a.png").write_bytes(b""), "a.png: is not a readable image"),
])
def test_folders_of_non_images_are_refused(tmp_path, capsys, setup, expected):
    folder = tmp_path / "views"
    folder.mkdir()
    setup(folder)
    assert expected in refusal([str(folder), "--out", str(tmp_path / "c.yaml")], capsys)


def test_missing_input_a_single_image_or_a_text_file_is_refused(board_folder, tmp_path, capsys):
    out = ["--out", str(tmp_path / "c.yaml")]
    assert "not found" in refusal([str(tmp_path / "absent"), *out], capsys)
    assert "is a single image" in refusal([str(board_folder / "view_00.png"), *out], capsys)
    (tmp_path / "drive.txt").write_text("no video\n")
    assert "cannot open this file as a video" in refusal([str(tmp_path / "drive.txt"), *out], capsys)


def test_a_few_views_of_another_size_are_skipped_and_named(checkerboard_views, checkerboard_result):
    odd = [("odd 1.png", np.pad(checkerboard_views[3], ((0, 1), (0, 1)), mode="edge")),  # 641x481, as re-saved
           ("odd 2.png", checkerboard_views[5][:240, :320])]
    views = labelled(checkerboard_views)
    images = views[:4] + odd[:1] + views[4:] + odd[1:]
    result = calibrate(images, CHECKERBOARD)
    assert result.skipped_for_size == ("odd 1.png", "odd 2.png") and result.image_size_hw == SIZE_HW
    assert result.images_seen == result.views_used == 15  # the 640x480 images alone
    assert result.warnings == ("2 of 17 images skipped: their size differs from the 640x480 of the images used "
                               "(intrinsics are in pixels of one resolution): odd 1.png (641x481), "
                               "odd 2.png (320x240)",)
    assert result.intrinsics.fx == pytest.approx(checkerboard_result.intrinsics.fx, rel=1e-9)  # the same views


def test_the_size_with_most_board_views_is_used_whatever_comes_first(checkerboard_views):
    blank = [(f"blank {i}.png", np.full((240, 320), 128, np.uint8)) for i in range(20)]  # more images, no board
    result = calibrate(blank + labelled(checkerboard_views), CHECKERBOARD)
    assert result.image_size_hw == SIZE_HW and len(result.skipped_for_size) == 20
    assert "20 of 35 images skipped" in result.warnings[0] and "blank 0.png (320x240)" in result.warnings[0]
    assert "and 8 more" in result.warnings[0]  # twelve named, the rest counted


def test_too_few_views_left_at_the_size_used_are_refused_naming_what_was_skipped(checkerboard_views):
    images = labelled(checkerboard_views[:5]) + [("small.png", checkerboard_views[9][:240, :320])] + \
        [(f"grey {i}.png", np.full(SIZE_HW, 128, np.uint8)) for i in range(2)]
    with pytest.raises(FlowvoError, match=r"found in only 5 of 7 images of 640x480 \(others skipped for their "
                                          r"size\) \(not in grey 0.png, grey 1.png\); calibration needs at least 8"):
        calibrate(images, CHECKERBOARD)


def test_images_without_the_board_are_named(checkerboard_views, checkerboard_result):
    grey = [(f"grey {i}.png", np.full(SIZE_HW, 128, np.uint8)) for i in range(2)]
    result = calibrate(grey[:1] + labelled(checkerboard_views) + grey[1:], CHECKERBOARD)
    assert result.without_board == ("grey 0.png", "grey 1.png") and result.skipped_for_size == ()
    assert result.images_seen == 17 and result.views_found == 15 and result.warnings == ()
    assert result.intrinsics.fx == pytest.approx(checkerboard_result.intrinsics.fx, rel=1e-9)


@pytest.mark.parametrize("square_m", [1e6, 1e-7, None])
@pytest.mark.parametrize("model", ["plumb_bob", "equidistant"])
def test_the_square_size_does_not_change_the_intrinsics(checkerboard_views, square_m, model):
    """OpenCV's solvers stop on a change relative to all their parameters, the boards' translations among
    them: in board units of 1e6 they stopped early (cy 2.6 px off on these views). They solve in whole squares
    now, the same numbers whatever the unit."""
    reference = calibrate(labelled(checkerboard_views), CHECKERBOARD, model)
    result = calibrate(labelled(checkerboard_views), Board("checkerboard", ROWS, COLS, square_m), model)
    for name in ("fx", "fy", "cx", "cy"):
        assert getattr(result.intrinsics, name) == pytest.approx(getattr(reference.intrinsics, name), rel=1e-7)  # the
        # last bits move with the unit's rounding (1e-7 m squares: 3e-9); the bug put cy 2.6 px (1 %) off
    np.testing.assert_allclose(result.distortion.coefficients, reference.distortion.coefficients, atol=1e-7)
    assert result.rms_px == pytest.approx(reference.rms_px, rel=1e-4)  # the poses scaled back to the board's unit


DASHCAM_PHOTOS = SHARED / "data" / "real" / "dashcam_udacity" / "camera_cal"


def test_a_real_dash_cams_photos_calibrate_skipping_and_naming_the_odd_ones(tmp_path, capsys):
    """20 photos as shipped: two are 1281x721, the board is not found whole in three."""
    if not DASHCAM_PHOTOS.is_dir():
        pytest.skip(f"shared dash-cam photos not found at {DASHCAM_PHOTOS}")
    out = tmp_path / "cam.yaml"
    assert main(["calibrate", str(DASHCAM_PHOTOS), "--rows", "6", "--cols", "9", "--out", str(out), "-q"]) == 0
    printed = capsys.readouterr().out
    assert "found in 15 of the 18 1280x720 images (2 of another size skipped, see below)" in printed
    names = [f"{DASHCAM_PHOTOS}/calibration{n}.jpg" for n in (1, 4, 5, 15, 7)]
    assert f"board not found in 3: {names[0]}, {names[1]}, {names[2]}\n" in printed
    assert f"warning: 2 of 20 images skipped: their size differs from the 1280x720 of the images used " \
           f"(intrinsics are in pixels of one resolution): {names[3]} (1281x721), {names[4]} (1281x721)" in printed
    camera = read_camera_file(out)
    assert camera.image_size_hw == (720, 1280)
    assert camera.intrinsics.fx == pytest.approx(1157, rel=0.01)  # plain OpenCV on the 18 photos: 1156.5
    assert camera.intrinsics.fy == pytest.approx(1153, rel=0.01)


def test_a_board_always_facing_the_camera_is_refused(plumb_bob_rays):
    poses = varied_poses(10, PLUMB_BOB, CHECKERBOARD_SIZE_M, seed=3, max_tilt_deg=3.0)
    images = render(plumb_bob_rays, checkerboard_texture(ROWS, COLS, SQUARE_PX), SQUARE_M, poses)
    with pytest.raises(FlowvoError, match=r"normals span \d+ deg; at least 20 needed"):
        calibrate(labelled(images), CHECKERBOARD)


def test_a_board_only_in_the_middle_of_the_image_is_refused(plumb_bob_rays):
    poses = varied_poses(10, PLUMB_BOB, CHECKERBOARD_SIZE_M, seed=4, distance_m=(1.4, 1.6), reach=0.03)
    images = render(plumb_bob_rays, checkerboard_texture(ROWS, COLS, SQUARE_PX), SQUARE_M, poses)
    with pytest.raises(FlowvoError, match=r"corners cover only \d+% of the image .* at least 25% needed"):
        calibrate(labelled(images), CHECKERBOARD)


@pytest.mark.parametrize("kwargs, expected", [
    ({"kind": "charuco", "square_m": 0.03}, "needs --square and --marker"),
    ({"kind": "charuco", "square_m": 0.03, "marker_m": 0.03}, "must be smaller than the square"),
    ({"kind": "charuco", "square_m": 0.03, "marker_m": 0.02, "dictionary": "DICT_9X9"}, "unknown ArUco dictionary"),
    ({"kind": "checkerboard", "rows": 2}, "at least 3 inner corners"),
    ({"kind": "hexagons"}, "unknown board"),
])
def test_impossible_boards_are_refused(kwargs, expected):
    with pytest.raises(FlowvoError, match=expected):
        Board(**{"rows": 6, "cols": 9, **kwargs})


def test_a_dictionary_too_small_for_the_charuco_board_is_refused(tmp_path, capsys):
    (tmp_path / "a.png").write_bytes(cv2.imencode(".png", np.zeros((8, 8), np.uint8))[1].tobytes())
    assert main(["calibrate", str(tmp_path), "--board", "charuco", "--rows", "12", "--cols", "12", "--square", "0.03",
                 "--marker", "0.02", "--out", str(tmp_path / "c.yaml")]) == 2
    assert "holds 72 markers; DICT_4X4_50 has only 50" in capsys.readouterr().err


def test_spread_views_keeps_the_extremes_and_the_order_and_drops_repeats():
    descriptors = [np.array([x]) for x in (0.0, 0.1, 0.5, 0.52, 1.0, 0.9)]
    assert spread_views(descriptors, 3) == [0, 2, 4]
    assert spread_views(descriptors, 10) == list(range(6))
    assert spread_views(descriptors, 10, repeat_distance=0.05) == [0, 1, 2, 4, 5]  # 0.52 repeats 0.5
    assert spread_views([np.zeros(8)] * 5, 10, repeat_distance=0.02) == [0]


def test_a_board_held_still_is_refused_however_many_frames_show_it(checkerboard_views):
    images = labelled(checkerboard_views[:3] * 4)
    with pytest.raises(FlowvoError, match="found in 12 of 12 images but from only 3 distinct positions"):
        calibrate(images, CHECKERBOARD)


def test_tilt_spread_is_the_largest_angle_between_board_normals():
    rotations = [np.zeros(3), np.radians([25.0, 0, 0]), np.radians([0, -10.0, 0]), np.radians([0, 0, 70.0])]
    assert tilt_spread_deg(rotations) == pytest.approx(np.degrees(np.arccos(np.cos(np.radians(25)) *
                                                                            np.cos(np.radians(10)))))
    assert tilt_spread_deg([np.zeros(3), np.radians([0, 0, 90.0])]) == pytest.approx(0.0, abs=1e-6)


def test_coverage_counts_grid_cells_holding_a_corner():
    quarter = np.array([[x, y] for x in np.linspace(0, 319, 20) for y in np.linspace(0, 239, 20)])
    assert coverage_fraction([quarter], SIZE_HW) == 0.25
    assert coverage_fraction([quarter, quarter + [320, 240]], SIZE_HW) == 0.5
    assert coverage_fraction([np.array([[-3.0, 500.0]])], SIZE_HW) == 1 / 64  # clipped to the border cells


def test_image_folders_are_read_sorted_by_name_every_nth(board_folder):
    images = open_calibration_images(board_folder, every=4)
    labels = [label for label, _ in images.frames()]
    assert images.count == 4 and [Path(label).name for label in labels] == [f"view_{i:02d}.png" for i in (0, 4, 8, 12)]
