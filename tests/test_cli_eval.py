import json

import numpy as np
import pytest
from swaying_drive import swaying_drive

from flowvo.cli import build_parser, main
from flowvo.cli.run import _bowl_warning, _mounting_note, _mounting_words, _unscaled_warning, _view_notes
from flowvo.geometry import chain_planar, chain_se3, relative_motions, so3_exp
from flowvo.metrics.error_split import turn_rotation, with_direction_turned


def test_every_subcommand_has_help(capsys):
    parser = build_parser()
    commands = parser._subparsers._group_actions[0].choices
    assert "eval" in commands
    for name, sub in commands.items():
        assert sub.format_help().startswith(f"usage: flowvo {name}")


def test_the_camera_mounting_flags_reach_the_run_and_a_roll_past_15_degrees_is_refused(capsys):
    from flowvo.cli.drive_options import run_options

    drive = ["run", "--out", "o", "--video", "v.mp4"]
    options = run_options(build_parser().parse_args([*drive, "--camera-pitch", "-2.5", "--camera-roll", "4.5"]), "o")
    assert (options.camera_pitch_deg, options.camera_roll_deg) == (-2.5, 4.5)
    assert run_options(build_parser().parse_args(drive), "o").camera_roll_deg is None
    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args([*drive, "--camera-roll", "16"])
    assert exit_.value.code == 2 and "--camera-roll" in capsys.readouterr().err


def test_eval_writes_metrics_and_plots(kitti_poses_dir, example_results_dir, tmp_path, capsys):
    code = main(
        [
            "eval",
            "--gt", str(kitti_poses_dir / "09.txt"),
            "--pred", str(example_results_dir / "example_1" / "09.txt"),
            "--out", str(tmp_path),
        ]
    )
    assert code == 0
    printed = capsys.readouterr().out
    assert "2.6068 %" in printed and "deg/m" in printed and "deg/100m" in printed
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    for key in ("t_err_percent", "r_err_deg_per_m", "r_err_deg_per_100m", "per_length", "per_speed", "ate_rmse_m"):
        assert key in metrics
    for png in ("path_xz.png", "t_err_vs_length.png", "r_err_vs_speed.png", "frame_error_histograms.png"):
        assert (tmp_path / png).read_bytes()[:4] == b"\x89PNG"
    assert not list(tmp_path.glob(".*tmp"))


def test_eval_reads_a_constant_turn_of_every_step_as_the_direction_offset(tmp_path, capsys):
    """A prediction whose every step is the truth's turned 0.3 degrees right and 0.2 down in its camera frame (a
    truth given in a camera frame turned against the images'): eval prints and records that offset, also over a
    prediction of every second frame only (its steps the sums of two turned steps)."""
    truth = chain_planar(np.c_[np.full(80, 1.0), np.zeros(80)])  # 80 m straight ahead
    turned = with_direction_turned(truth, turn_rotation(0.3, -0.2))
    np.savetxt(tmp_path / "gt.txt", truth[:, :3].reshape(-1, 12))
    np.savetxt(tmp_path / "pred.txt", turned[:, :3].reshape(-1, 12))
    every_second = np.c_[np.arange(0, 81, 2), turned[::2, :3].reshape(-1, 12)]
    np.savetxt(tmp_path / "half.txt", every_second, fmt=["%d"] + ["%.12e"] * 12)
    for pred, steps in (("pred.txt", 80), ("half.txt", 40)):
        out = tmp_path / pred.replace(".txt", "_eval")
        assert main(["eval", "--gt", str(tmp_path / "gt.txt"), "--pred", str(tmp_path / pred), "--lengths", "20",
                     "--out", str(out)]) == 0
        assert f"azimuth +0.300 deg (right +), elevation -0.200 deg (up +), {steps} steps" in capsys.readouterr().out
        offset = json.loads((out / "metrics.json").read_text())["direction_offset_deg"]
        assert offset == {"azimuth_right": pytest.approx(0.3, abs=1e-9), "elevation_up": pytest.approx(-0.2, abs=1e-9),
                          "steps": steps, "min_step_m": 0.3}


def test_eval_reads_every_step_pitched_up_alike_as_the_rotation_per_step(tmp_path, capsys):
    """A prediction whose every step pitches 2 millidegrees nose up more than the truth's through gentle bends:
    eval prints and records that bias (over every second frame, 4 a step) and a yaw gain of 1."""
    truth = chain_planar(np.c_[np.full(120, 0.8), 0.01 * np.sin(np.arange(120) / 15.0)])
    steps = relative_motions(truth)
    steps[:, :3, :3] = steps[:, :3, :3] @ so3_exp([np.radians(0.002), 0.0, 0.0])
    pitched = chain_se3(steps)
    np.savetxt(tmp_path / "gt.txt", truth[:, :3].reshape(-1, 12))
    np.savetxt(tmp_path / "pred.txt", pitched[:, :3].reshape(-1, 12), fmt="%.15e")
    np.savetxt(tmp_path / "half.txt", np.c_[np.arange(0, 121, 2), pitched[::2, :3].reshape(-1, 12)],
               fmt=["%d"] + ["%.15e"] * 12)
    for pred, steps, pitch in (("pred.txt", 120, 2.0), ("half.txt", 60, 4.0)):
        out = tmp_path / pred.replace(".txt", "_eval")
        assert main(["eval", "--gt", str(tmp_path / "gt.txt"), "--pred", str(tmp_path / pred), "--lengths", "20",
                     "--out", str(out)]) == 0
        assert f"pitch {pitch:+.2f} (up +), yaw +0.00 (right +), roll +0.00 mdeg" in capsys.readouterr().out
        record = json.loads((out / "metrics.json").read_text())["rotation_per_step_mdeg"]
        assert record["pitch_up"] == pytest.approx(pitch, rel=1e-4)  # over two steps, turned between them
        assert (record["yaw_right"], record["roll_right_down"]) == (pytest.approx(0.0, abs=0.01),) * 2
        assert record["steps"] == steps and record["yaw_slope"] == pytest.approx(1.0, abs=1e-6)


def test_eval_reads_a_run_on_a_later_clock_as_its_clock_offset_and_scores_it_read_back(tmp_path, capsys):
    """A prediction that is the truth read 0.2 frames later (swaying through bends): eval prints and records the
    offset and the metric of the prediction read back at the truth's times (near zero); a prediction of every second
    frame gets no record (its frames are not one after another)."""
    truth, later = swaying_drive(np.arange(200.0)), swaying_drive(np.arange(200.0) + 0.2)
    np.savetxt(tmp_path / "gt.txt", truth[:, :3].reshape(-1, 12), fmt="%.15e")
    np.savetxt(tmp_path / "pred.txt", later[:, :3].reshape(-1, 12), fmt="%.15e")
    np.savetxt(tmp_path / "half.txt", np.c_[np.arange(0, 200, 2), later[::2, :3].reshape(-1, 12)],
               fmt=["%d"] + ["%.15e"] * 12)
    assert main(["eval", "--gt", str(tmp_path / "gt.txt"), "--pred", str(tmp_path / "pred.txt"), "--lengths", "20",
                 "--out", str(tmp_path / "e")]) == 0
    assert "clock offset              +0.20" in capsys.readouterr().out
    record = json.loads((tmp_path / "e" / "metrics.json").read_text())
    assert record["clock_offset"]["frames"] == pytest.approx(0.2, abs=0.01)
    assert record["clock_offset"]["r_err_deg_per_m"] < 0.05 * record["r_err_deg_per_m"]
    assert main(["eval", "--gt", str(tmp_path / "gt.txt"), "--pred", str(tmp_path / "half.txt"), "--lengths", "20",
                 "--out", str(tmp_path / "h")]) == 0
    assert "clock offset" not in capsys.readouterr().out
    assert json.loads((tmp_path / "h" / "metrics.json").read_text())["clock_offset"] is None


def test_bad_pose_file_gives_one_line_error_and_exit_2(tmp_path, capsys):
    (tmp_path / "bad.txt").write_text("1 2 3\n")
    bad = str(tmp_path / "bad.txt")
    code = main(["eval", "--gt", bad, "--pred", bad, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.count("\n") == 0 and "bad.txt:1: expected 12 numbers" in err
    assert not (tmp_path / "o").exists()


def test_a_run_whose_steps_mostly_lack_a_scale_warns_and_names_the_step_records():
    def summary(unscaled: int) -> dict:
        kinds = {"road+ratio": 80, "none": 30, "standstill": 40}
        return {"steps": "00_steps.csv", "scale_window": {"steps_measured_by": kinds, "unscaled_steps": unscaled}}

    warning = _unscaled_warning(summary(30), "OUT")
    assert warning.startswith("warning: 30 of 110 moving steps") and "OUT/00_steps.csv" in warning
    assert _unscaled_warning(summary(11), "OUT") is None  # a tenth of the moving steps is tolerated
    assert _unscaled_warning({"steps": None}, "OUT") is None  # a method without a window


def test_a_pitch_and_a_roll_are_said_in_words_down_or_up_right_or_left():
    assert _mounting_words(8.3, 0.0) == ["pitched 8.3 deg down"]
    assert _mounting_words(-1.8, 0.0) == ["pitched 1.8 deg up"]
    assert _mounting_words(-2.14, 6.0, 1) == ["pitched 2.1 deg up", "rolled 6.0 deg (right side down)"]
    assert _mounting_words(0.0, -4.0) == ["rolled 4 deg (left side down)"] and _mounting_words(0.0, 0.0) == []


def test_the_mounting_note_names_what_was_taken_and_advises_what_differs_from_what_was_given():
    def planes(pitches, rolls):
        return {"pitches_taken_deg": pitches, "rolls_taken_deg": rolls, "refused_as_tilted": 21}

    assert _mounting_note(planes([], []), 0.0, 0.0) is None
    pitched = _mounting_note(planes([8.3], [0.0]), 0.0, 0.0)
    assert "pitched 8.3 deg down" in pitched and "--camera-pitch 8.3 measures" in pitched and "roll" not in pitched
    rolled = _mounting_note(planes([3.0], [5.3]), 3.0, 0.0)  # the pitch was given: only the roll was taken
    assert "rolled 5.3 deg (right side down)" in rolled and "--camera-roll 5.3 measures" in rolled
    assert "--camera-pitch" not in rolled and "pitched" not in rolled and "21 refused as tilted" in rolled
    both = _mounting_note(planes([8.0, -2.1], [6.0, 4.4]), 0.0, 6.0)  # the last take counts
    assert "pitched 2.1 deg up, rolled 4.4 deg" in both and "--camera-pitch -2.1 --camera-roll 4.4 measures" in both
    given_back = _mounting_note(planes([-2.1], [4.4]), -2.1, 4.4)  # taken as given: nothing to advise
    assert "as given" in given_back and "--camera" not in given_back


def test_a_road_that_bends_away_from_its_plane_is_warned_of_and_kitti_s_is_not():
    assert _bowl_warning({"far_road_off_plane_share": 0.2813}).startswith(
        "warning: the road 10-20 camera heights ahead lies 28 % of the height below the plane")
    assert _bowl_warning({"far_road_off_plane_share": -0.0353}) is None  # real KITTI 03
    assert _bowl_warning({"far_road_off_plane_share": None}) is None and _bowl_warning({}) is None


def test_a_bonnet_and_a_still_layer_kept_out_of_the_road_are_told_and_a_clean_view_says_nothing():
    clean = {"still_regions": {"road_cells": 0, "track_cells": 0, "view_ends_at_row": None},
             "static_layer": {"share": 0.0031, "removed_from_moving_frame": None}}
    assert _view_notes(clean) == [] and _view_notes({}) == []  # real KITTI; flowvo-pair's summary as well
    dash_cam = {"still_regions": {"road_cells": 3, "track_cells": 10, "view_ends_at_row": 668},
                "static_layer": {"share": 0.2516, "removed_from_moving_frame": 40}}
    bonnet, layer = _view_notes(dash_cam)
    assert bonnet.startswith("note: the frames' view ends at row 668 (a bonnet")
    assert "0.25 of the road's texture" in layer and "from moving frame 40 on" in layer
