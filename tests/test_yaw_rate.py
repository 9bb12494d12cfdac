"""A car's yaw rate changes smoothly: a step whose fitted yaw rate jumps beyond what a car can steer takes the
last yaw rate taken; a change that holds over two steps is real and is taken from then on."""

import numpy as np
import pytest

from flowvo.odometry.yaw_rate import YawRateCheck

UP = np.array([0.0, 1.0, 0.0])
SLOW = 2.0  # m/s: below the speed from which the yaw rate is not checked


def yawing(deg: float) -> np.ndarray:
    """A step's rotation vector (rad) turning ``deg`` about the camera's vertical axis, with a little pitch."""
    return np.array([np.radians(0.05), np.radians(deg), 0.0])


def test_a_single_step_that_turns_too_far_takes_the_last_yaw_rate_and_the_next_good_one_is_taken():
    check = YawRateCheck(UP, max_acceleration_deg_s2=60.0, min_change_deg=0.2)  # 0.6 deg a step at 10 Hz
    steady = yawing(1.6)
    assert check.checked(steady, 0.1, SLOW) is steady
    smooth = yawing(2.1)  # 0.5 deg more: within what a car steers in 0.1 s
    assert check.checked(smooth, 0.1, SLOW) is smooth
    taken = check.checked(yawing(3.1), 0.1, SLOW)  # 1.0 deg more for one step: a failed fit
    np.testing.assert_allclose(taken, smooth)
    assert check.refused_steps == 1
    back = yawing(2.2)
    assert check.checked(back, 0.1, SLOW) is back  # the next step agrees with the last one taken


def test_a_change_that_holds_over_two_steps_is_real():
    check = YawRateCheck(UP, max_acceleration_deg_s2=60.0, min_change_deg=0.2)
    check.checked(yawing(0.0), 0.1, SLOW)
    np.testing.assert_allclose(check.checked(yawing(1.0), 0.1, SLOW), yawing(0.0))  # refused once
    held = yawing(1.1)  # the next step agrees with the refused one: the change was real
    assert check.checked(held, 0.1, SLOW) is held
    following = yawing(1.2)
    assert check.checked(following, 0.1, SLOW) is following
    assert check.refused_steps == 1


def test_the_bound_scales_with_the_square_of_the_step_time_down_to_the_floor_and_only_yaw_counts():
    check = YawRateCheck(UP, max_acceleration_deg_s2=60.0, min_change_deg=0.2)
    check.checked(yawing(0.0), 0.2, SLOW)
    two_degrees = yawing(2.0)  # at 5 Hz the bound is 2.4 deg a step
    assert check.checked(two_degrees, 0.2, SLOW) is two_degrees
    check.forget()
    check.checked(yawing(0.0), 1 / 30, SLOW)  # at 30 frames/s 0.07 deg, below the floor of 0.2
    within_floor = yawing(0.15)
    assert check.checked(within_floor, 1 / 30, SLOW) is within_floor
    np.testing.assert_allclose(check.checked(yawing(0.45), 1 / 30, SLOW), within_floor)
    pitched = within_floor + np.array([np.radians(1.0), 0.0, 0.0])  # a bump pitches the car: not a yaw change
    assert check.checked(pitched, 1 / 30, SLOW) is pitched


def test_the_last_rate_is_taken_over_the_steps_own_duration_and_forgetting_takes_the_next_as_it_comes():
    check = YawRateCheck(UP, max_acceleration_deg_s2=60.0, min_change_deg=0.2)
    check.checked(yawing(1.0), 0.1, SLOW)
    np.testing.assert_allclose(check.checked(yawing(6.0), 0.2, SLOW), 2 * yawing(1.0))  # the last rate over 0.2 s
    check.forget()
    anything = yawing(-5.0)
    assert check.checked(anything, 0.1, SLOW) is anything


@pytest.mark.parametrize("pitch_deg", [0.0, 10.0])
def test_yaw_is_measured_about_the_given_vertical_axis(pitch_deg):
    pitch = np.radians(pitch_deg)
    up = np.array([0.0, np.cos(pitch), np.sin(pitch)])  # a camera pitched down: the car's vertical axis tilts
    check = YawRateCheck(up, max_acceleration_deg_s2=60.0, min_change_deg=0.2)
    check.checked(np.zeros(3), 0.1, SLOW)
    turn = np.radians(1.0) * up
    np.testing.assert_allclose(check.checked(turn, 0.1, SLOW), np.zeros(3))
    roll = np.radians(1.0) * np.array([0.0, -np.sin(pitch), np.cos(pitch)])  # about the optical axis, level
    assert check.checked(roll, 0.1, SLOW) is roll


def test_at_speed_every_yaw_rate_is_taken_and_becomes_the_last_one():
    check = YawRateCheck(UP, max_acceleration_deg_s2=60.0, min_change_deg=0.2, max_speed_mps=6.0)
    check.checked(yawing(4.0), 0.1, 13.0)
    straightening = yawing(3.0)  # 1 deg less in 0.1 s at 13 m/s: a synthetic path may do it; taken
    assert check.checked(straightening, 0.1, 13.0) is straightening
    np.testing.assert_allclose(check.checked(yawing(1.0), 0.1, None), straightening)  # unknown speed: checked
    assert check.refused_steps == 1


def test_the_rotation_a_step_finally_took_is_the_rate_the_next_is_checked_against():
    """At speed a wrong fit is taken by this check (the direction check refuses it and fits its rotation again);
    told the rotation the step took, the next, slower step's good fit is taken, not refused against the wrong one."""
    check = YawRateCheck(UP, max_acceleration_deg_s2=60.0, min_change_deg=0.2, max_speed_mps=6.0)
    check.checked(yawing(3.0), 0.1, 6.1)
    check.checked(yawing(5.2), 0.1, 6.1)  # a failed fit, taken at speed
    check.took(yawing(2.8), 0.1)  # what the step took after the direction check
    good = yawing(3.1)
    assert check.checked(good, 0.1, 5.9) is good
    assert check.refused_steps == 0
