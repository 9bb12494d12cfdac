"""flowvo.report.drive_summary: distance, duration, speeds and heading change of drives with known answers."""

import numpy as np
import pytest

from flowvo.errors import FlowvoError
from flowvo.report.drive_summary import drive_summary


def drive(step_lengths_m, heading_steps_deg=None, rate_hz=10.0, start_s=0.0, heading0_deg=0.0):
    """Poses (N, 4, 4) and times (N,) of a level camera that turns by ``heading_steps_deg`` (left positive) then
    moves ``step_lengths_m`` along its new forward axis, one step per frame at ``rate_hz``."""
    steps = np.asarray(step_lengths_m, dtype=np.float64)
    turns = np.zeros(len(steps)) if heading_steps_deg is None else np.asarray(heading_steps_deg, np.float64)
    headings = np.radians(heading0_deg + np.concatenate([[0.0], np.cumsum(turns)]))
    poses = np.tile(np.eye(4), (len(steps) + 1, 1, 1))
    for k, psi in enumerate(headings):
        forward, down = np.array([-np.sin(psi), 0.0, np.cos(psi)]), np.array([0.0, 1.0, 0.0])
        poses[k, :3, :3] = np.column_stack([np.cross(down, forward), down, forward])
        if k:
            poses[k, :3, 3] = poses[k - 1, :3, 3] + steps[k - 1] * forward
    return poses, start_s + np.arange(len(steps) + 1) / rate_hz


def test_a_straight_drive_at_constant_speed():
    summary = drive_summary(*drive([1.0] * 30))  # 1 m a step at 10 Hz: 10 m/s for 3 s
    assert summary == pytest.approx({"distance_m": 30.0, "duration_s": 3.0, "mean_speed_mps": 10.0,
                                     "top_speed_mps": 10.0, "heading_change_deg": 0.0}, abs=1e-9)
    assert set(summary) == {"distance_m", "duration_s", "mean_speed_mps", "top_speed_mps", "heading_change_deg"}
    assert all(type(value) is float for value in summary.values())  # JSON-ready


def test_top_speed_is_the_fastest_one_second_stretch():
    summary = drive_summary(*drive([1.0] * 20 + [2.0] * 20))  # 2 s at 10 m/s, then 2 s at 20 m/s
    assert summary["mean_speed_mps"] == pytest.approx(15.0)
    assert summary["top_speed_mps"] == pytest.approx(20.0)


def test_a_single_wild_step_is_averaged_over_its_second_not_reported_as_a_speed():
    summary = drive_summary(*drive([1.0] * 15 + [5.0] + [1.0] * 15))  # one 5 m step (50 m/s) among 1 m steps
    assert summary["top_speed_mps"] == pytest.approx(14.0)  # 5 m + 9 x 1 m in the second holding it


def test_top_speed_slides_between_frames():
    # 25 frames/s: 1 s is 25 steps; speeds 10 m/s then 30 m/s for 0.6 s then 10 m/s again
    steps = [0.4] * 30 + [1.2] * 15 + [0.4] * 30
    summary = drive_summary(*drive(steps, rate_hz=25.0))
    assert summary["top_speed_mps"] == pytest.approx(0.6 * 30 + 0.4 * 10)  # the fast 0.6 s inside the second
    assert summary["duration_s"] == pytest.approx(3.0)


def test_a_drive_shorter_than_a_second_reports_its_mean_as_top_speed():
    summary = drive_summary(*drive([1.0, 3.0, 2.0]))  # 0.3 s
    assert summary["mean_speed_mps"] == pytest.approx(20.0) and summary["top_speed_mps"] == pytest.approx(20.0)


def test_times_are_taken_as_given_irregular_and_from_any_origin():
    poses, _ = drive([1.0, 1.0, 1.0])
    summary = drive_summary(poses, np.array([100.0, 100.1, 100.5, 101.5]))
    assert summary["duration_s"] == pytest.approx(1.5) and summary["mean_speed_mps"] == pytest.approx(2.0)
    # stretches of 1 s: [100.0, 101.0] covers 1 + 1 + 0.5 m; [100.5, 101.5] covers 1 m; [100.1, 101.1] 1.6 m
    assert summary["top_speed_mps"] == pytest.approx(2.5)


@pytest.mark.parametrize("turns_deg, expected_deg", [
    ([3.0] * 30, 90.0),  # a quarter circle to the left
    ([-3.0] * 30, -90.0),  # to the right
    ([3.0] * 30 + [-3.0] * 30, 0.0),  # left then back right
    ([12.0] * 30, 360.0),  # a full loop counter-clockwise seen from above
    ([-20.0] * 27, -540.0),  # one and a half loops clockwise
])
def test_heading_change_is_signed_left_positive_and_counts_whole_turns(turns_deg, expected_deg):
    summary = drive_summary(*drive([1.0] * len(turns_deg), turns_deg, heading0_deg=170.0))  # across +-180
    assert summary["heading_change_deg"] == pytest.approx(expected_deg, abs=1e-9)
    assert summary["distance_m"] == pytest.approx(len(turns_deg))


def test_a_left_turn_moves_the_camera_towards_its_left():
    poses, times = drive([1.0] * 30, [3.0] * 30)
    assert poses[-1, 0, 3] < -10  # world x is right: the path bends to -x
    assert drive_summary(poses, times)["heading_change_deg"] > 0


def test_a_standing_camera_has_zero_speeds():
    poses, times = drive([0.0] * 20)
    assert drive_summary(poses, times) == {"distance_m": 0.0, "duration_s": pytest.approx(2.0), "mean_speed_mps": 0.0,
                                           "top_speed_mps": 0.0, "heading_change_deg": 0.0}


@pytest.mark.parametrize("poses, times, expected", [
    (np.tile(np.eye(4), (1, 1, 1)), np.zeros(1), "at least 2 poses"),
    (np.tile(np.eye(4), (3, 1, 1)), np.zeros(2), r"poses \(N, 4, 4\) and times \(N,\)"),
    (np.zeros((3, 3, 4)), np.arange(3.0), r"poses \(N, 4, 4\)"),
    (np.tile(np.eye(4), (3, 1, 1)), np.array([0.0, 0.1, 0.1]), "strictly increasing"),
    (np.tile(np.eye(4), (3, 1, 1)), np.array([0.0, np.nan, 0.2]), "finite"),
])
def test_impossible_inputs_are_refused(poses, times, expected):
    with pytest.raises(FlowvoError, match=expected):
        drive_summary(poses, times)
