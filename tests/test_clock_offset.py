"""The truth's clock against the images' (flowvo.metrics.clock_offset): a run that is the truth read a known fraction of
a frame later is found that much ahead, and read back at the truth's times it scores as the truth."""

import numpy as np
import pytest
from swaying_drive import swaying_drive

from flowvo.geometry import so3_exp
from flowvo.metrics.clock_offset import ClockOffset, clock_offset, read_at_frames, with_clock_offset_removed
from flowvo.metrics.error_split import error_split, kitti_errors
from flowvo.metrics.rotation_bias import with_step_rotations_changed

LENGTHS_M = (20.0, 50.0)
FRAMES = np.arange(300.0)
TRUTH = swaying_drive(FRAMES)


@pytest.mark.parametrize("lead", [0.25, -0.15])
def test_a_run_that_is_the_truth_read_later_is_found_that_far_ahead_and_read_back_scores_as_the_truth(lead):
    run = swaying_drive(FRAMES + lead)
    offset = clock_offset(TRUTH, run)
    assert offset.frames == pytest.approx(lead, abs=0.01)
    assert offset.explained > 0.99 and 0 < offset.standard_error < 0.002
    assert kitti_errors(TRUTH, run, LENGTHS_M)["r_err_deg_per_m"] > 0.003
    read_back = with_clock_offset_removed(run, offset)
    inner = slice(1, -1)  # the ends are read along their first and last step
    np.testing.assert_allclose(read_back[inner, :3, :3], TRUTH[inner, :3, :3], atol=2e-4)
    np.testing.assert_allclose(read_back[inner, :3, 3], TRUTH[inner, :3, 3], atol=3e-3)  # straight between frames
    split = error_split(TRUTH, run, LENGTHS_M)
    assert split["clock_offset_removed"]["r_err_deg_per_m"] < 0.05 * split["run"]["r_err_deg_per_m"]


def test_a_run_on_the_truths_clock_has_no_offset_and_is_left_as_it_is():
    offset = clock_offset(TRUTH, TRUTH)
    assert offset == ClockOffset(0.0, 0.0, 297, 0.0)
    np.testing.assert_allclose(with_clock_offset_removed(TRUTH, offset), TRUTH, atol=1e-12)


def test_a_run_of_noisy_rotations_on_the_truths_clock_reads_no_lead_beyond_its_standard_error():
    noise = so3_exp(np.random.default_rng(7).normal(0.0, np.radians(0.02), (len(TRUTH) - 1, 3)))
    noisy = with_step_rotations_changed(TRUTH, noise)
    offset = clock_offset(TRUTH, noisy)
    assert 0.005 < offset.standard_error < 0.05
    assert abs(offset.frames) < 2.5 * offset.standard_error and offset.explained < 0.05


def test_a_truth_whose_rotation_never_changes_gives_no_offset_and_the_run_untouched():
    straight = np.tile(np.eye(4), (20, 1, 1))
    straight[:, 2, 3] = np.arange(20) * 1.0
    offset = clock_offset(straight, straight)
    assert np.isnan(offset.frames) and offset.steps == 17
    assert with_clock_offset_removed(straight, offset) is straight


def test_reading_poses_between_frames_follows_each_step_and_its_ends_extend_the_end_steps():
    turning = np.tile(np.eye(4), (4, 1, 1))
    turning[:, :3, :3] = so3_exp(np.array([[0.0, 0.1 * k, 0.0] for k in range(4)]))
    turning[:, 2, 3] = [0.0, 1.0, 3.0, 6.0]
    np.testing.assert_allclose(read_at_frames(turning, 0.0), turning, atol=1e-12)
    half = read_at_frames(turning, 0.5)
    np.testing.assert_allclose(half[:3, 2, 3], [0.5, 2.0, 4.5])
    assert half[3, 2, 3] == pytest.approx(7.5)  # beyond the last frame along the last step (3 m)
    np.testing.assert_allclose(half[:, :3, :3], so3_exp(np.array([[0.0, 0.1 * k + 0.05, 0.0] for k in range(4)])),
                               atol=1e-12)
    assert read_at_frames(turning, -1.0)[0, 2, 3] == pytest.approx(-1.0)
    with pytest.raises(ValueError, match="two frames"):
        read_at_frames(turning[:1], 0.5)
