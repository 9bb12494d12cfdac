"""A fast car's direction of travel: a fitted direction further off the camera's forward axis than a car at
speed can travel is refused for the last one taken at speed; a slow car's is never checked."""

import numpy as np

from flowvo.odometry.travel_direction import TravelDirection

FORWARD = np.array([0.0, 0.0, 1.0])


def heading(deg: float) -> np.ndarray:
    """A unit direction in the camera's ground plane, ``deg`` from straight ahead towards the right."""
    angle = np.radians(deg)
    return np.array([np.sin(angle), 0.0, np.cos(angle)])


def test_at_speed_a_direction_within_the_limit_is_taken_one_beyond_gives_way_to_the_last_taken():
    travel = TravelDirection(FORWARD, max_angle_deg=20.0, min_speed_mps=6.0)
    turned = heading(15.0)
    assert travel.checked(turned, speed_mps=12.0) is turned
    for wrong in (heading(25.0), -heading(0.0), heading(-90.0)):  # sideways or backwards at 12 m/s
        assert travel.checked(wrong, speed_mps=12.0) is turned
    assert travel.kept_steps == 3


def test_before_any_direction_at_speed_the_forward_axis_stands_in():
    travel = TravelDirection(heading(3.0), max_angle_deg=20.0, min_speed_mps=6.0)  # a camera mounted 3 deg off
    np.testing.assert_allclose(travel.checked(-heading(3.0), speed_mps=8.0), heading(3.0))
    kept = heading(22.0)  # within 20 degrees of that forward axis, 22 of straight ahead
    assert travel.checked(kept, speed_mps=8.0) is kept


def test_a_slow_car_or_one_of_unknown_speed_takes_every_direction_and_does_not_set_the_last():
    travel = TravelDirection(FORWARD, max_angle_deg=20.0, min_speed_mps=6.0)
    swing, backwards = heading(60.0), -heading(0.0)  # a turning camera at walking pace; reversing
    assert travel.checked(swing, speed_mps=2.0) is swing
    assert travel.checked(backwards, speed_mps=None) is backwards
    assert travel.kept_steps == 0
    np.testing.assert_array_equal(travel.checked(heading(90.0), speed_mps=6.0), FORWARD)  # not the slow ones
