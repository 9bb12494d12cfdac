"""The rotations' bias per step (flowvo.metrics.rotation_bias): the mean step rotation error about the camera's axes,
the yaw gain in turns and how the turns read at each speed, and the run with the bias taken off or its yaw rescaled, on
drives with known answers."""

import numpy as np
import pytest

from flowvo.geometry import chain_planar, chain_se3, relative_motions, so3_exp, so3_log
from flowvo.metrics.error_split import error_split
from flowvo.metrics.rotation_bias import (
    rotation_bias,
    step_rotation_errors,
    turn_reading_by_speed,
    with_rotation_bias_removed,
    with_yaw_scaled,
)

BENDS = chain_planar(np.c_[np.full(200, 0.8), 0.01 * np.sin(np.arange(200) / 15.0)])  # 160 m of gentle bends


def with_step_rotations(truth: np.ndarray, rotation_of_step) -> np.ndarray:
    """The truth's steps, each translation in the camera frame of its start as it is, each rotation replaced by
    ``rotation_of_step(k, R_true)``, chained from the truth's first pose."""
    steps = relative_motions(truth)
    for k, step in enumerate(steps):
        step[:3, :3] = rotation_of_step(k, step[:3, :3])
    return chain_se3(steps, truth[0])


def test_every_step_pitched_up_alike_reads_as_that_bias_and_is_taken_off_exactly():
    """Each step pitched 0.002 rad nose up after the truth's (about +x, which turns forward towards -y, up): the bias
    reads exactly that, the run's path climbs, and with the bias taken off the run is the truth again."""
    pitch = np.array([0.002, 0.0, 0.0])
    run = with_step_rotations(BENDS, lambda k, R: R @ so3_exp(pitch))
    assert run[-1, 1, 3] < -1.0  # y is down: the path climbed
    bias = rotation_bias(BENDS, run)
    np.testing.assert_allclose(bias.mean_error_rad, pitch, atol=1e-12)
    assert bias.steps == 200
    np.testing.assert_allclose(with_rotation_bias_removed(BENDS, run, bias.mean_error_rad), BENDS, atol=1e-9)
    split = error_split(BENDS, run, (20.0, 50.0))
    assert split["run"]["t_err_percent"] > 1.0
    assert split["rotation_bias_removed"]["t_err_percent"] < 1e-6


def test_turns_read_short_give_their_yaw_slope_whatever_the_bias():
    """Every step's rotation 1 % short of the truth's: the slope of the run's yaw against the truth's is 0.99, and
    the mean error is the mean of the missing hundredths; a yaw error of 3 millidegrees on every step besides leaves
    the gain as it is."""
    run = with_step_rotations(BENDS, lambda k, R: so3_exp(0.99 * so3_log(R)))
    biased = with_step_rotations(BENDS, lambda k, R: so3_exp(0.99 * so3_log(R) + [0.0, np.radians(0.003), 0.0]))
    assert rotation_bias(BENDS, biased).yaw_slope == pytest.approx(0.99, abs=1e-9)
    bias = rotation_bias(BENDS, run)
    true_yaw = so3_log(relative_motions(BENDS)[:, :3, :3])[:, 1]
    turning = np.abs(true_yaw) >= np.radians(0.2)
    assert bias.yaw_slope == pytest.approx(0.99, abs=1e-12)
    assert bias.turning_steps == int(turning.sum()) > 50
    np.testing.assert_allclose(bias.mean_error_rad, [0.0, -0.01 * true_yaw.mean(), 0.0], atol=1e-12)


def test_steps_the_truth_stood_still_on_are_left_out():
    """A stop of ten steps whose run turns 0.01 rad each (a held rotation) does not move the bias; the stop's steps
    keep their rotation when the bias is taken off."""
    step_m = np.r_[np.full(50, 0.8), np.zeros(10), np.full(50, 0.8)]
    truth = chain_planar(np.c_[step_m, np.zeros(110)])
    run = with_step_rotations(truth, lambda k, R: R @ so3_exp([0.0, 0.01 if 50 <= k < 60 else 0.0, 0.0]))
    bias = rotation_bias(truth, run)
    assert bias.steps == 100
    np.testing.assert_allclose(bias.mean_error_rad, 0.0, atol=1e-15)
    assert np.isnan(bias.yaw_slope) and bias.turning_steps == 0
    np.testing.assert_allclose(step_rotation_errors(truth, run)[55], [0.0, 0.01, 0.0], atol=1e-15)
    np.testing.assert_allclose(with_rotation_bias_removed(truth, run, np.array([0.0, 0.003, 0.0]))[51:61, :3, :3],
                               run[51:61, :3, :3] @ so3_exp([0.0, -0.15, 0.0]), atol=1e-12)


def test_no_bias_leaves_a_run_orthonormal_only_to_4e_7_as_it_is():
    """KITTI's rotations are orthonormal to about 4e-7: with nothing to take off, the run's poses come back as they
    were (no rotation shrinks over the chained steps)."""
    run = with_step_rotations(BENDS, lambda k, R: R @ so3_exp([0.001 * np.sin(k), 0.002 * np.cos(k / 3), 0.0]))
    run[:, :3, :3] *= 1 + 4e-7
    np.testing.assert_allclose(with_rotation_bias_removed(BENDS, run, np.zeros(3)), run, atol=1e-12)


def test_poses_of_other_frames_are_refused_and_two_steps_give_no_slope():
    with pytest.raises(ValueError, match="same N"):
        rotation_bias(BENDS, BENDS[:-1])
    turning = chain_planar(np.array([[1.0, 0.1], [1.0, 0.1]]))
    assert np.isnan(rotation_bias(turning, turning).yaw_slope)


def test_turns_read_short_are_scaled_back_to_the_truth_by_their_slope():
    """Every step's yaw 1 % short: divided by the slope the run is the truth again and scores nothing, where as it is
    its heading lags after each bend; a gain of 1 leaves the poses as they were."""
    run = with_step_rotations(BENDS, lambda k, R: so3_exp(so3_log(R) * [1.0, 0.99, 1.0]))
    slope = rotation_bias(BENDS, run).yaw_slope
    assert slope == pytest.approx(0.99, abs=1e-12)
    np.testing.assert_allclose(with_yaw_scaled(run, 1.0 / slope), BENDS, atol=1e-9)
    np.testing.assert_allclose(with_yaw_scaled(run, 1.0), run, atol=1e-12)
    split = error_split(BENDS, run, (20.0, 50.0))
    assert split["run"]["t_err_percent"] > 0.05
    assert split["yaw_slope_removed"]["t_err_percent"] < 1e-6
    assert split["rotation_bias_removed"]["t_err_percent"] > 0.05  # a gain is no bias: its mean error is near zero


def test_turns_read_by_speed_band_whichever_way_they_turn():
    """100 steps at 4 m/s read every turn as it is, then 100 at 10 m/s read every turn 2 % short, left and right
    alike: the bands say 1 and 0.98; steps turning less than 0.2 degrees and bands without a turn are left out."""
    step_m = np.r_[np.full(100, 0.4), np.full(100, 1.0)]
    turn_rad = 0.005 * np.sign(np.sin(np.arange(200) / 7.0 + 0.1))  # 0.29 degrees a step, left and right in turn
    turn_rad[:10] = 0.001  # 0.06 degrees: not a turn
    truth = chain_planar(np.c_[step_m, turn_rad])
    run = with_step_rotations(truth, lambda k, R: so3_exp(so3_log(R) * (0.98 if k >= 100 else 1.0)))
    readings = turn_reading_by_speed(truth, run, 0.1 * np.arange(201))
    assert [(row.low_mps, row.high_mps, row.steps) for row in readings] == [(3.0, 6.0, 90), (9.0, 13.0, 100)]
    assert readings[0].read == pytest.approx(1.0, abs=1e-12) and readings[1].read == pytest.approx(0.98, abs=1e-12)
    assert readings[1].true_turn_deg == pytest.approx(100 * np.degrees(0.005), rel=1e-9)
    with pytest.raises(ValueError, match="one increasing time per frame"):
        turn_reading_by_speed(truth, run, 0.1 * np.arange(200))
