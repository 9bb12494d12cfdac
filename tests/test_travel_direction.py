"""A car's direction of travel: a fitted direction further off the camera's forward axis than a car at speed can
travel is refused for the last one taken at speed (a slow car's is not checked for that); one against the step's
turn, or one whose elevation jumped from the recent ones', is refused at any speed for the last one taken."""

import numpy as np

from flowvo.odometry.travel_direction import TravelDirection

FORWARD = np.array([0.0, 0.0, 1.0])
RIGHT = np.array([1.0, 0.0, 0.0])


def heading(deg: float, up_deg: float = 0.0) -> np.ndarray:
    """A unit direction ``deg`` from straight ahead towards the right, ``up_deg`` above the camera's ground plane."""
    angle, up = np.radians(deg), np.radians(up_deg)
    return np.array([np.sin(angle) * np.cos(up), -np.sin(up), np.cos(angle) * np.cos(up)])


def test_at_speed_a_direction_within_the_limit_is_taken_one_beyond_gives_way_to_the_last_taken():
    travel = TravelDirection(FORWARD, RIGHT, max_angle_deg=20.0, min_speed_mps=6.0)
    turned = heading(15.0)
    assert travel.checked(turned, speed_mps=12.0) is turned
    for wrong in (heading(25.0), -heading(0.0), heading(-90.0)):  # sideways or backwards at 12 m/s
        assert travel.checked(wrong, speed_mps=12.0) is turned
    assert travel.kept_steps == 3


def test_before_any_direction_at_speed_the_forward_axis_stands_in():
    travel = TravelDirection(heading(3.0), heading(93.0), max_angle_deg=20.0, min_speed_mps=6.0)  # mounted 3 deg off
    np.testing.assert_allclose(travel.checked(-heading(3.0), speed_mps=8.0), heading(3.0))
    kept = heading(22.0)  # within 20 degrees of that forward axis, 22 of straight ahead
    assert travel.checked(kept, speed_mps=8.0) is kept


def test_a_slow_car_or_one_of_unknown_speed_takes_every_direction_and_does_not_set_the_last_at_speed():
    travel = TravelDirection(FORWARD, RIGHT, max_angle_deg=20.0, min_speed_mps=6.0)
    swing, backwards = heading(60.0), -heading(0.0)  # a turning camera at walking pace; reversing
    assert travel.checked(swing, speed_mps=2.0) is swing
    assert travel.checked(backwards, speed_mps=None) is backwards
    assert travel.kept_steps == 0
    np.testing.assert_array_equal(travel.checked(heading(90.0), speed_mps=6.0), FORWARD)  # not the slow ones


def test_a_direction_against_the_turn_gives_way_to_the_last_one_taken_at_any_speed():
    """Turning right, a camera ahead of the rear axle travels to the right of its axis: a fit 25 degrees to the left
    (a yaw too large traded against a sideways direction) is refused for the last direction taken, slow or fast;
    one 8 degrees to the left (within the 10 degree margin), or any direction of a step turning under 0.3 degrees,
    is taken."""
    travel = TravelDirection(FORWARD, RIGHT)
    right_turn, left_turn = np.radians(1.5), np.radians(-1.5)
    into_the_turn = heading(4.0)
    assert travel.checked(into_the_turn, speed_mps=2.5, yaw_rad=right_turn) is into_the_turn
    assert travel.checked(heading(-25.0), speed_mps=2.5, yaw_rad=right_turn) is into_the_turn
    assert travel.checked(heading(25.0), speed_mps=2.5, yaw_rad=left_turn) is into_the_turn
    assert travel.checked(heading(-15.0), speed_mps=12.0, yaw_rad=right_turn) is into_the_turn  # also at speed
    assert travel.against_turn_steps == 3 and travel.kept_steps == 0
    slightly_against = heading(-8.0)
    assert travel.checked(slightly_against, speed_mps=2.5, yaw_rad=right_turn) is slightly_against
    barely_turning = heading(-25.0)
    assert travel.checked(barely_turning, speed_mps=2.5, yaw_rad=np.radians(0.2)) is barely_turning
    assert travel.against_turn_steps == 3


def test_a_direction_whose_elevation_jumped_gives_way_to_the_last_one_taken_at_any_speed():
    """Over the last directions taken (the median of their elevations: 1 degree up), one 7 degrees down (a pitch
    traded against an elevation, facing a wall) is refused for the last one taken, slow or fast; one 3.5 degrees
    down (within 5 degrees) is taken. The first three directions are not held to any."""
    travel = TravelDirection(FORWARD, RIGHT)
    first = heading(0.0, 9.0)
    assert travel.checked(first, speed_mps=2.5) is first  # nothing to hold the first ones to
    for up_deg in (1.0, 1.0):
        travel.checked(heading(2.0, up_deg), speed_mps=2.5)
    last = heading(1.0, 0.5)
    assert travel.checked(last, speed_mps=2.5) is last
    assert travel.checked(heading(4.0, -7.0), speed_mps=2.5) is last
    assert travel.checked(heading(0.0, -6.0), speed_mps=12.0) is last
    assert travel.elevation_jump_steps == 2 and travel.kept_steps == 0
    lower = heading(1.0, -3.5)
    assert travel.checked(lower, speed_mps=2.5) is lower
    assert travel.elevation_jump_steps == 2


def test_the_recent_elevations_carry_a_camera_mounted_pitched_up():
    """A camera pitched 5 degrees up whose car's axes are not known yet (the camera's own): its car travels 5
    degrees below the camera's axis on every step, and those directions are taken; one level with the camera's axis
    is the jump."""
    travel = TravelDirection(FORWARD, RIGHT)
    for _ in range(5):
        down = heading(0.0, -5.0)
        assert travel.checked(down, speed_mps=8.0) is down
    assert travel.checked(heading(0.0, 0.5), speed_mps=8.0) is down
    assert travel.elevation_jump_steps == 1
