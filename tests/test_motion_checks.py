"""The checks of a step's motion up to scale (flowvo.odometry.motion_checks.MotionChecks): the rotation from the
rotation key frame, a yaw rate that jumped below 6 m/s, a sideways direction at speed, a direction against the
turn, one whose elevation jumped, and their counts, on
exact tracks of a scene projected through a pinhole K."""

import numpy as np

from flowvo.geometry import so3_exp, so3_log
from flowvo.odometry.motion_checks import MAX_KEY_ROTATION_OFF_DEG, MotionChecks
from flowvo.odometry.two_view import EssentialMotion

K = np.array([[359.0, 0.0, 303.0], [0.0, 359.0, 92.0], [0.0, 0.0, 1.0]])
THRESHOLD_PX = 0.25
rng = np.random.default_rng(7)
SCENE = np.c_[rng.uniform(-15, 15, 300), rng.uniform(-5, 1.0, 300), rng.uniform(8, 50, 300)]  # camera frame, m
FORWARD = np.array([0.0, 0.0, 1.0])
SIDEWAYS = np.array([-1.0, 0.0, 0.0])  # to the left: the side a camera turning by a positive yaw() travels to


def project(points: np.ndarray) -> np.ndarray:
    pixels = points @ K.T
    return pixels[:, :2] / pixels[:, 2:]


def yaw(rad: float) -> np.ndarray:
    """``R_next_prev`` of a camera turning ``rad`` to the left (about its y axis, down)."""
    return so3_exp(np.array([0.0, rad, 0.0]))


def step(R: np.ndarray, direction: np.ndarray = FORWARD, length_m: float = 1.0
         ) -> tuple[EssentialMotion, tuple[np.ndarray, np.ndarray]]:
    """The exact motion (``R_next_prev``, unit ``t_dir``) of a camera travelling ``length_m`` along ``direction``
    (its own frame) while turning by ``R``, and the scene's tracks under it (float64 pixels)."""
    t_dir = -R @ direction
    tracks = project(SCENE), project(SCENE @ R.T + t_dir * length_m)
    return EssentialMotion(R, t_dir, np.ones(len(SCENE), bool)), tracks


def fit_of(R: np.ndarray, t_dir: np.ndarray) -> EssentialMotion:
    """A pair's fit with rotation ``R`` and direction ``t_dir``, every track an inlier."""
    return EssentialMotion(R, t_dir, np.ones(len(SCENE), bool))


def checks() -> MotionChecks[str]:
    return MotionChecks(K, np.eye(3), THRESHOLD_PX)


def test_a_rotation_key_frames_rotation_replaces_the_pairs_and_the_direction_is_fitted_again_under_it():
    """At 30 frames/s the step b -> c is measured from key frame a: the key's fitted rotation a -> c after the
    rotation a -> b gives b -> c exactly, though the pair's fit is 0.3 degrees off; the direction then comes
    back exact from the tracks, and the step is counted."""
    motion_checks = checks()
    R_ab, (true_bc, tracks_bc) = yaw(0.004), step(yaw(0.006), length_m=0.3)
    motion_checks.advance((0.0, "a"), 1 / 30, R_ab)
    assert motion_checks.rotation_key.frame == "a"
    R_ac = true_bc.R @ R_ab
    off = fit_of(so3_exp(np.radians([0.3, 0.0, 0.0])) @ true_bc.R, true_bc.t_dir)
    checked = motion_checks.checked(off, fit_of(R_ac, -R_ac @ FORWARD), tracks_bc, 1 / 30, 9.0)
    np.testing.assert_allclose(checked.R, true_bc.R, atol=1e-12)
    np.testing.assert_allclose(checked.t_dir, true_bc.t_dir, atol=1e-9)
    assert motion_checks.summary()["rotation_key_steps"] == 1


def test_a_rotation_key_frames_rotation_far_off_the_pairs_is_a_failed_fit_and_the_pair_is_kept():
    motion_checks = checks()
    R_ab, (true_bc, tracks_bc) = yaw(0.004), step(yaw(0.006), length_m=0.3)
    motion_checks.advance((0.0, "a"), 1 / 30, R_ab)
    off_key = so3_exp(np.radians([MAX_KEY_ROTATION_OFF_DEG + 0.1, 0.0, 0.0])) @ true_bc.R @ R_ab
    checked = motion_checks.checked(true_bc, fit_of(off_key, true_bc.t_dir), tracks_bc, 1 / 30, 9.0)
    assert checked is true_bc
    assert motion_checks.summary()["rotation_key_steps"] == 0


def test_a_yaw_rate_jump_below_6_mps_takes_the_last_yaw_rate_and_the_direction_the_tracks_give_under_it():
    """At 3 m/s a step turning 0.01 rad, then a fit turning 0.04 rad (1.7 degrees more in 0.1 s: no car steers
    that fast) of tracks that turned 0.01 rad again: the step takes 0.01 rad and the true direction."""
    motion_checks = checks()
    first, tracks = step(yaw(0.01), length_m=0.3)
    assert motion_checks.checked(first, None, tracks, 0.1, 3.0) is first
    overturned = fit_of(yaw(0.04), np.array([0.0, 0.0, -1.0]))
    checked = motion_checks.checked(overturned, None, tracks, 0.1, 3.0)
    np.testing.assert_allclose(checked.R, first.R, atol=1e-12)
    np.testing.assert_allclose(checked.t_dir, first.t_dir, atol=1e-9)
    assert motion_checks.summary()["yaw_refused_steps"] == 1


def test_a_yaw_rate_jump_at_6_mps_is_taken():
    motion_checks = checks()
    first, tracks = step(yaw(0.01))
    motion_checks.checked(first, None, tracks, 0.1, 6.0)
    overturned, _ = step(yaw(0.04))
    assert motion_checks.checked(overturned, None, tracks, 0.1, 6.0) is overturned
    assert motion_checks.summary()["yaw_refused_steps"] == 0


def test_a_sideways_direction_at_speed_takes_the_last_direction_with_the_rotation_the_tracks_give_along_it():
    """At 10 m/s the fit of a forward step turning 0.02 rad comes back sideways with its rotation 0.6 degrees
    off: the step goes forward (the last direction taken at speed; none yet: the camera's axis) with the true
    rotation, refitted to the tracks along that direction."""
    motion_checks = checks()
    true, tracks = step(yaw(0.02))
    sideways = fit_of(yaw(0.03), -yaw(0.03) @ SIDEWAYS)
    checked = motion_checks.checked(sideways, None, tracks, 0.1, 10.0)
    np.testing.assert_allclose(checked.R, true.R, atol=1e-9)
    np.testing.assert_allclose(-checked.R.T @ checked.t_dir, FORWARD, atol=1e-9)
    assert motion_checks.summary()["direction_kept_steps"] == 1


def test_a_sideways_direction_below_6_mps_is_taken():
    motion_checks = checks()
    sideways, tracks = step(yaw(0.02), SIDEWAYS, length_m=0.3)
    assert motion_checks.checked(sideways, None, tracks, 0.1, 3.0) is sideways
    assert motion_checks.summary()["direction_kept_steps"] == 0


def test_a_direction_refused_at_speed_leaves_its_refitted_yaw_rate_for_the_next_check():
    """The rotation the tracks gave along the last direction (0.02 rad in 0.1 s) is the rate the next step is
    checked against: a following step at 3 m/s turning 0.012 rad passes (0.46 degrees of change), where after a
    step taken at the sideways fit's 0.03 rad it is refused (1.03 degrees)."""
    motion_checks = checks()
    true, tracks = step(yaw(0.02))
    motion_checks.checked(fit_of(yaw(0.03), -yaw(0.03) @ SIDEWAYS), None, tracks, 0.1, 10.0)
    np.testing.assert_allclose(motion_checks.yaw_rate.taken_rate, [0.0, 0.2, 0.0], atol=1e-8)
    slower, slow_tracks = step(yaw(0.012), length_m=0.3)
    assert motion_checks.checked(slower, None, slow_tracks, 0.1, 3.0) is slower
    after_the_wrong_rate = checks()
    turned, turned_tracks = step(yaw(0.03))
    after_the_wrong_rate.checked(turned, None, turned_tracks, 0.1, 10.0)
    assert after_the_wrong_rate.checked(slower, None, slow_tracks, 0.1, 3.0) is not slower


def test_a_direction_whose_elevation_jumped_takes_the_last_direction_with_the_rotation_the_tracks_give_along_it():
    """After three forward steps at 3 m/s, a fit of the next (turning 0.01 rad) comes back 8 degrees low with its
    pitch 0.2 degrees up: the step goes forward (the last direction taken) with the true rotation, refitted to the
    tracks along it."""
    motion_checks = checks()
    true, tracks = step(yaw(0.01), length_m=0.3)
    for _ in range(3):
        assert motion_checks.checked(true, None, tracks, 0.1, 3.0) is true
    pitched = so3_exp(np.array([np.radians(0.2), 0.0, 0.0])) @ true.R
    low = np.array([0.0, np.sin(np.radians(8.0)), np.cos(np.radians(8.0))])  # y down: 8 degrees below the axis
    checked = motion_checks.checked(fit_of(pitched, -pitched @ low), None, tracks, 0.1, 3.0)
    np.testing.assert_allclose(checked.R, true.R, atol=1e-9)
    np.testing.assert_allclose(-checked.R.T @ checked.t_dir, FORWARD, atol=1e-9)
    assert motion_checks.summary()["direction_elevation_steps"] == 1


def test_the_summary_counts_the_steps_each_check_changed():
    motion_checks = checks()
    R_ab, (true_bc, tracks_bc) = yaw(0.004), step(yaw(0.006), length_m=0.3)
    motion_checks.advance((0.0, "a"), 1 / 30, R_ab)
    motion_checks.checked(true_bc, fit_of(true_bc.R @ R_ab, true_bc.t_dir), tracks_bc, 1 / 30, 3.0)  # key rotation
    motion_checks.checked(fit_of(yaw(0.04), true_bc.t_dir), None, tracks_bc, 1 / 30, 3.0)  # the yaw rate jumped
    true, tracks = step(yaw(0.02))
    motion_checks.checked(fit_of(yaw(0.03), -yaw(0.03) @ SIDEWAYS), None, tracks, 0.1, 10.0)  # sideways at speed
    motion_checks.checked(fit_of(yaw(0.02), yaw(0.02) @ SIDEWAYS), None, tracks, 0.1, 3.0)  # against the turn
    assert motion_checks.summary() == {"direction_kept_steps": 1, "direction_against_turn_steps": 1,
                                       "direction_elevation_steps": 0, "yaw_refused_steps": 1,
                                       "rotation_key_steps": 1}


def test_forget_drops_the_rotation_key_frame_and_the_last_yaw_rate():
    motion_checks = checks()
    first, tracks = step(yaw(0.01), length_m=0.3)
    motion_checks.advance((0.0, "a"), 1 / 30, first.R)
    motion_checks.checked(first, None, tracks, 0.1, 3.0)
    motion_checks.forget()
    assert motion_checks.rotation_key.frame is None
    overturned = fit_of(yaw(0.04), first.t_dir)
    assert motion_checks.checked(overturned, None, tracks, 0.1, 3.0) is overturned  # nothing to jump from


def test_the_car_axes_turned_by_a_pitch_taken_from_the_drive_judge_the_direction_of_travel():
    """A direction of travel 25 degrees above the camera's optical axis is refused at speed for a camera taken for
    level (the gate is 20 degrees); once the drive's pitch of 8 degrees down is taken, the car's forward axis is 8
    degrees above the optical axis (a camera looking down sees the level road ahead above its centre) and the same
    direction, 17 degrees off it, is taken."""
    from flowvo.camera import pitch_rotation
    from flowvo.odometry.travel_direction import TravelDirection

    above = np.array([0.0, -np.sin(np.radians(25.0)), np.cos(np.radians(25.0))])  # y down
    level = TravelDirection(np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    assert np.array_equal(level.checked(above, speed_mps=10.0), level.last_taken) and level.kept_steps == 1
    checks = MotionChecks(np.eye(3), np.eye(3), 0.25)
    checks.turn_car_axes(pitch_rotation(8.0).T)
    np.testing.assert_allclose(checks.travel.forward, [0.0, -np.sin(np.radians(8.0)), np.cos(np.radians(8.0))],
                               atol=1e-12)
    np.testing.assert_allclose(checks.yaw_rate.up, [0.0, np.cos(np.radians(8.0)), np.sin(np.radians(8.0))],
                               atol=1e-12)
    assert np.array_equal(checks.travel.checked(above, speed_mps=10.0), above) and checks.travel.kept_steps == 0


def test_a_slow_turns_yaw_traded_against_a_direction_against_the_turn_is_fitted_again_along_the_last_direction():
    """Turning right 1.2 degrees over 0.25 m at 2.5 m/s, travelling 4 degrees right of the axis, after a step turning
    1.4 degrees: a fit 0.7 degrees too far (a change of yaw rate a car can make) with its direction 28 degrees to
    the left (what a wall filling the view let through on a synthetic replay) is refused, and the rotation fitted
    along the last step's direction (3 degrees right) is within 0.05 degrees of the truth."""
    motion_checks = checks()
    last, last_tracks = step(yaw(np.radians(-1.4)), np.array([np.sin(np.radians(3.0)), 0.0, np.cos(np.radians(3.0))]),
                             0.25)
    assert motion_checks.checked(last, None, last_tracks, 0.1, 2.5) is last
    direction = np.array([np.sin(np.radians(4.0)), 0.0, np.cos(np.radians(4.0))])
    true, tracks = step(yaw(np.radians(-1.2)), direction, 0.25)
    wrong_R = yaw(np.radians(-1.9))
    wrong = fit_of(wrong_R, -wrong_R @ np.array([-np.sin(np.radians(28.0)), 0.0, np.cos(np.radians(28.0))]))
    checked = motion_checks.checked(wrong, None, tracks, 0.1, 2.5)
    off_deg = np.degrees(np.linalg.norm(so3_log(checked.R @ true.R.T)))
    assert off_deg < 0.05
    assert motion_checks.summary()["direction_against_turn_steps"] == 1
