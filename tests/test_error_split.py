"""The drive-level diagnostic (flowvo.metrics.error_split): path ratios per stretch against speed and turn, and
the error split with the true step lengths and with the true rotations, on trajectories with known answers."""

import numpy as np
import pytest

from flowvo.geometry import chain_planar, chain_se3, relative_motions, so3_exp
from flowvo.metrics.error_split import (
    direction_offset,
    distance_bounds,
    error_split,
    frame_bounds,
    on_true_path,
    path_ratio,
    stretches,
    turn_rotation,
    with_direction_turned,
    with_true_lengths,
    with_true_rotations,
)

LENGTHS_M = (20.0, 50.0)


def drive(step_m: np.ndarray, turn_rad: np.ndarray) -> np.ndarray:
    """Poses (N+1, 4, 4) of a level drive of steps ``step_m`` (m) each turning ``turn_rad`` (right positive)."""
    return chain_planar(np.c_[step_m, turn_rad])


def scaled_about_start(T_world_cam: np.ndarray, factor: float) -> np.ndarray:
    scaled = T_world_cam.copy()
    scaled[:, :3, 3] = T_world_cam[0, :3, 3] + factor * (T_world_cam[:, :3, 3] - T_world_cam[0, :3, 3])
    return scaled


STRAIGHT = drive(np.full(120, 1.0), np.zeros(120))  # 120 m straight ahead
BENDS = drive(np.full(200, 0.8), 0.01 * np.sin(np.arange(200) / 15.0))  # 160 m of gentle bends


def test_lengths_all_2_percent_long_give_path_ratio_1_02_in_every_stretch():
    long = scaled_about_start(BENDS, 1.02)
    assert path_ratio(BENDS, long) == pytest.approx(1.02, rel=1e-12)
    for bounds in (frame_bounds(len(BENDS), 50), distance_bounds(BENDS, 50.0)):
        assert [s.path_ratio for s in stretches(BENDS, long, bounds)] == pytest.approx([1.02] * len(bounds),
                                                                                        rel=1e-12)


def test_lengths_all_2_percent_long_leave_no_error_with_the_true_lengths_and_all_of_it_with_their_own():
    """On a straight drive of 1 m steps each devkit segment of L m ends at the first frame beyond L, L + 1 m on:
    a 2 % long run is off by 2 % of L + 1 (ten 20 m segments, seven 50 m ones). Its rotations and directions
    with the true lengths score 0, the true rotations with its lengths as much as the run, and its lengths
    divided by its path ratio 0."""
    split = error_split(STRAIGHT, scaled_about_start(STRAIGHT, 1.02), LENGTHS_M)
    expected = (10 * 2.0 * 21 / 20 + 7 * 2.0 * 51 / 50) / 17
    assert split["run"]["segments"] == 17
    assert split["run"]["t_err_percent"] == pytest.approx(expected, rel=1e-6)
    assert split["true_rotations"]["t_err_percent"] == pytest.approx(expected, rel=1e-6)
    assert split["true_lengths"]["t_err_percent"] < 1e-9
    assert split["one_factor"]["t_err_percent"] < 1e-9
    assert split["run"]["path_ratio"] == pytest.approx(1.02, rel=1e-12)
    assert split["true_lengths"]["path_ratio"] == pytest.approx(1.0, rel=1e-12)
    assert split["true_rotations"]["path_ratio"] == pytest.approx(1.02, rel=1e-12)
    assert split["run"]["segments"] == split["true_lengths"]["segments"] > 0


def test_wrong_rotations_with_true_lengths_are_all_in_the_rotations_share():
    """A run whose every step turns 0.002 rad too far at the true lengths: the true rotations with its lengths
    give the truth back exactly; with the true lengths the run is itself."""
    turned = drive(np.full(200, 0.8), 0.01 * np.sin(np.arange(200) / 15.0) + 0.002)
    np.testing.assert_allclose(with_true_rotations(BENDS, turned), BENDS, atol=1e-9)
    np.testing.assert_allclose(with_true_lengths(BENDS, turned), turned, atol=1e-9)
    split = error_split(BENDS, turned, LENGTHS_M)
    assert split["true_rotations"]["t_err_percent"] < 1e-6
    assert split["true_lengths"]["t_err_percent"] == pytest.approx(split["run"]["t_err_percent"], rel=1e-6)
    assert split["run"]["t_err_percent"] > 1.0


def test_the_true_lengths_keep_each_steps_own_rotation_and_direction():
    """A run of 3-D steps (pitch and roll too) whose lengths are off: with the true lengths each step keeps its
    own rotation and unit direction and takes the true length."""
    rng = np.random.default_rng(4)
    motions = np.tile(np.eye(4), (30, 1, 1))
    motions[:, :3, :3] = so3_exp(rng.normal(0.0, 0.01, (30, 3)))
    directions = np.c_[rng.normal(0.0, 0.05, (30, 2)), np.ones(30)]
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    motions[:, :3, 3] = directions * rng.uniform(0.5, 1.5, (30, 1))
    true_lengths = np.linspace(0.9, 1.1, 30)
    true_motions = motions.copy()
    true_motions[:, :3, :3] = so3_exp(rng.normal(0.0, 0.01, (30, 3)))  # the truth turns otherwise
    true_motions[:, :3, 3] = directions[::-1] * true_lengths[:, None]
    fixed = relative_motions(with_true_lengths(chain_se3(true_motions), chain_se3(motions)))
    np.testing.assert_allclose(fixed[:, :3, :3], motions[:, :3, :3], atol=1e-12)
    np.testing.assert_allclose(fixed[:, :3, 3], directions * true_lengths[:, None], atol=1e-12)


def test_a_step_the_run_stood_still_on_takes_the_true_direction_and_length():
    run = STRAIGHT.copy()
    run[10:, :3, 3] -= np.array([0.0, 0.0, 1.0])  # frame 10 where frame 9 was: a standstill step
    np.testing.assert_allclose(with_true_lengths(STRAIGHT, run), STRAIGHT, atol=1e-12)


def test_stretches_by_frames_give_their_mean_speed_and_turn():
    """50 steps at 1 m per 0.1 s turning 0.6 degrees right each, then 50 at 0.5 m per 0.1 s turning 0.3
    degrees left: 10 m/s through 30 degrees right, 5 m/s through 15 degrees left."""
    step_m = np.r_[np.full(50, 1.0), np.full(50, 0.5)]
    turn = np.radians(np.r_[np.full(50, 0.6), np.full(50, -0.3)])
    truth = drive(step_m, turn)
    rows = stretches(truth, truth, frame_bounds(len(truth), 50))
    assert [(s.first_frame, s.last_frame) for s in rows] == [(0, 50), (50, 100)]
    assert [s.true_length_m for s in rows] == pytest.approx([50.0, 25.0], rel=1e-12)
    assert [s.mean_speed_mps for s in rows] == pytest.approx([10.0, 5.0], rel=1e-12)
    assert [s.turn_deg for s in rows] == pytest.approx([30.0, -15.0], rel=1e-9)
    assert [s.path_ratio for s in rows] == [1.0, 1.0]


def test_stretch_speeds_follow_the_given_times():
    times_s = 0.1036 * np.arange(len(STRAIGHT))
    rows = stretches(STRAIGHT, STRAIGHT, frame_bounds(len(STRAIGHT), 60), times_s)
    assert [s.mean_speed_mps for s in rows] == pytest.approx([1.0 / 0.1036] * 2, rel=1e-12)
    with pytest.raises(ValueError, match="one time per frame"):
        stretches(STRAIGHT, STRAIGHT, frame_bounds(len(STRAIGHT), 60), times_s[:-1])


def test_the_last_stretch_holds_what_remains():
    assert frame_bounds(400, 50)[-1] == (350, 399)
    assert frame_bounds(401, 50)[-1] == (350, 400)
    assert distance_bounds(STRAIGHT, 50.0) == [(0, 50), (50, 100), (100, 120)]
    assert distance_bounds(STRAIGHT, 60.0) == [(0, 60), (60, 120)]
    assert distance_bounds(STRAIGHT, 500.0) == [(0, 120)]


def test_poses_of_other_frames_are_refused():
    with pytest.raises(ValueError, match="same frames"):
        path_ratio(STRAIGHT, STRAIGHT[:-1])
    with pytest.raises(ValueError, match="at least one step"):
        frame_bounds(100, 0)


def test_the_true_rotations_keep_a_truth_orthonormal_only_to_4e_7_exactly():
    """KITTI's rotations are orthonormal to about 4e-7: relative motions chained over 125 steps (100 m here)
    would stretch them enough for the devkit's trace to read 0.0099 deg/m; the split keeps the truth's own
    orientations, so its true-rotations run has no rotation error."""
    truth = BENDS.copy()
    truth[:, :3, :3] *= 1 + 4e-7
    run = scaled_about_start(truth, 1.02)
    split = error_split(truth, run, (100.0,))
    assert split["true_rotations"]["r_err_deg_per_m"] == 0.0
    np.testing.assert_array_equal(with_true_rotations(truth, run)[:, :3, :3], truth[:, :3, :3])


def test_the_turn_takes_the_forward_axis_right_by_the_azimuth_and_up_by_the_elevation():
    np.testing.assert_allclose(turn_rotation(90.0, 0.0) @ [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(turn_rotation(0.0, 90.0) @ [0.0, 0.0, 1.0], [0.0, -1.0, 0.0], atol=1e-15)  # y is down
    np.testing.assert_allclose(turn_rotation(30.0, 20.0) @ [0.0, 0.0, 1.0],
                               [np.cos(np.radians(20)) * np.sin(np.radians(30)), -np.sin(np.radians(20)),
                                np.cos(np.radians(20)) * np.cos(np.radians(30))], atol=1e-15)


def test_every_step_turned_alike_reads_as_the_offset_and_scores_nothing_once_it_is_removed():
    """A straight drive whose every step is turned 0.3 degrees right and 0.2 down in its camera frame: the offset
    reads exactly that; the run misses each devkit segment's end by the chord of the turn, |C z - z| of the L + 1
    m it spans (as in the 2 % long test), and once the offset is turned back nothing is left."""
    turn = turn_rotation(0.3, -0.2)
    run = with_direction_turned(STRAIGHT, turn)
    np.testing.assert_allclose(run[:, :3, :3], STRAIGHT[:, :3, :3], atol=0)
    offset = direction_offset(STRAIGHT, run)
    assert (offset.azimuth_deg, offset.elevation_deg, offset.steps) == (pytest.approx(0.3, abs=1e-9),
                                                                        pytest.approx(-0.2, abs=1e-9), 120)
    np.testing.assert_allclose(with_direction_turned(run, offset.turn().T), STRAIGHT, atol=1e-9)
    split = error_split(STRAIGHT, run, LENGTHS_M)
    chord = float(np.linalg.norm(turn @ [0.0, 0.0, 1.0] - [0.0, 0.0, 1.0]))
    assert split["run"]["t_err_percent"] == pytest.approx(100 * chord * (10 * 21 / 20 + 7 * 51 / 50) / 17, rel=1e-6)
    assert split["offset_removed"]["t_err_percent"] < 1e-9
    assert split["true_lengths_offset_removed"]["t_err_percent"] < 1e-9
    assert split["true_lengths"]["t_err_percent"] == pytest.approx(split["run"]["t_err_percent"], rel=1e-9)


def test_a_sideways_offset_through_bends_is_read_exactly_and_slow_steps_are_left_out():
    """Through gentle bends (chords off the forward axis) a pure sideways turn of every step adds its azimuth
    exactly; the offset is a median, so a few steps of noise do not move it, and steps under 0.3 m are not read."""
    step_m = np.r_[np.full(20, 0.1), np.full(180, 0.8)]
    truth = drive(step_m, 0.01 * np.sin(np.arange(200) / 15.0))
    steps = np.diff(with_direction_turned(truth, turn_rotation(-0.4, 0.0))[:, :3, 3], axis=0)
    steps[150:160] = np.diff(with_direction_turned(truth, turn_rotation(5.0, 0.0))[:, :3, 3], axis=0)[150:160]
    run = truth.copy()
    run[1:, :3, 3] = np.cumsum(steps, axis=0)  # ten steps 5 degrees right among 170 at 0.4 degrees left
    offset = direction_offset(truth, run)
    assert offset.steps == 180
    assert offset.azimuth_deg == pytest.approx(-0.4, abs=1e-9)
    assert offset.elevation_deg == pytest.approx(0.0, abs=1e-9)
    standing = np.tile(np.eye(4), (5, 1, 1))
    assert direction_offset(standing, standing).steps == 0


def test_on_the_true_path_a_run_keeps_only_its_rotations():
    """A run with the true rotations but every length 2 % long lies on the true path as the truth itself; one whose
    every step also pitches 3 millidegrees more keeps those orientations on the truth's positions."""
    np.testing.assert_allclose(on_true_path(BENDS, scaled_about_start(BENDS, 1.02)), BENDS, atol=1e-12)
    steps = relative_motions(BENDS)
    steps[:, :3, :3] = steps[:, :3, :3] @ so3_exp([np.radians(0.003), 0.0, 0.0])
    steps[:, :3, 3] *= 1.02
    pitched = chain_se3(steps)
    on_path = on_true_path(BENDS, pitched)
    np.testing.assert_allclose(on_path[:, :3, 3], BENDS[:, :3, 3], atol=1e-12)
    np.testing.assert_allclose(on_path[:, :3, :3], pitched[:, :3, :3], atol=1e-9)
    assert not np.allclose(on_path[:, :3, :3], BENDS[:, :3, :3], atol=1e-6)
