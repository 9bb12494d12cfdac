"""The smooth-speed prior: follows acceleration, ignores outliers, restarts after a stop."""

import numpy as np
import pytest

from flowvo.odometry.speed_prior import MAX_EXTRAPOLATION_S, RESTART_SPEED_MPS, SpeedPrior, robust_line_value


def test_a_line_through_exact_measurements_is_reproduced():
    times = np.arange(9) * 0.1
    assert robust_line_value(times, 2.0 + 3.0 * times, at_s=0.8) == pytest.approx(4.4, abs=1e-9)


def test_constant_acceleration_from_a_stop_is_followed_without_lag():
    prior = SpeedPrior()
    prior.stop(0.0)
    for i in range(1, 30):
        speed = prior.update(0.1 * i, 2.0 * 0.1 * i)  # 2 m/s^2
    assert speed == pytest.approx(2.0 * 2.9, abs=1e-6)


def test_a_wild_measurement_barely_moves_the_speed():
    prior = SpeedPrior()
    for i in range(10):
        prior.update(0.1 * i, 10.0)
    assert prior.update(1.0, 50.0) == pytest.approx(10.0, abs=0.05)  # beyond the plausible: rejected
    assert prior.update(1.1, 16.0) == pytest.approx(10.0, abs=1.0)  # a 60 % jump: moves it under 15 %


def test_a_missing_measurement_keeps_the_trend():
    prior = SpeedPrior()
    for i in range(9):
        prior.update(0.1 * i, 5.0 + 0.1 * i)
    assert prior.update(0.9, None) == pytest.approx(5.9, abs=1e-6)


def test_a_trend_is_held_once_the_measurements_stop_for_longer_than_the_extrapolation():
    prior = SpeedPrior()
    for i in range(9):
        prior.update(0.1 * i, 5.0 + 4.0 * 0.1 * i)  # 4 m/s^2 up to 0.8 s
    held = 5.0 + 4.0 * (0.8 + MAX_EXTRAPOLATION_S)
    speeds = [prior.update(0.1 * i, None) for i in range(9, 18)]  # 0.9 s without a measurement
    assert speeds[0] == pytest.approx(5.0 + 4.0 * 0.9, abs=1e-6)  # followed at first
    assert speeds[-1] == pytest.approx(held, abs=1e-6)  # then held, not 5 + 4 * 1.7
    assert max(speeds) == pytest.approx(held, abs=1e-6)


def test_no_measurement_yet_gives_none():
    assert SpeedPrior().update(0.0, None) is None


def _pulled_away_then_measured(after_standstill: bool, speed_mps: float) -> float:
    """The prior's speed at 0.7 s for ``speed_mps`` measured then, after pulling away at 3 m/s^2 from 0 s
    (a standstill seen there, or a speed of 0 measured)."""
    prior = SpeedPrior()
    if after_standstill:
        prior.stop(0.0)
    else:
        prior.update(0.0, 0.0)
    for i in range(1, 7):
        prior.update(0.1 * i, 3.0 * 0.1 * i)
    return prior.update(0.7, speed_mps)


def test_pulling_away_no_speed_beyond_what_1_g_reaches_since_the_standstill_is_taken():
    """A road plane ten times too far, 0.7 s after a standstill (synthetic drive 21): 39.8 m/s is refused
    and the speed follows the line of the measurements before it; a prior that saw no standstill takes it
    (Huber counts it, linearly)."""
    assert _pulled_away_then_measured(True, 39.8) == pytest.approx(2.1, abs=1e-9)
    assert _pulled_away_then_measured(False, 39.8) > 4.0
    prior = SpeedPrior()
    assert prior.max_speed_at(0.7) == prior.max_speed_mps  # no standstill seen: the speed limit alone
    prior.stop(0.0)
    assert prior.max_speed_at(0.7) == pytest.approx(RESTART_SPEED_MPS + 9.81 * 0.7)
    assert prior.max_speed_at(10.0) == prior.max_speed_mps  # long after: the speed limit again


def test_a_car_at_speed_cannot_stand_still_sooner_than_1_g_of_braking_allows():
    """Still images at 12 m/s (only distant scenery in view, past a crest) are no standstill until a car
    braking at 1 g would be down to the restart speed; slow cars, stopped ones and unknown speeds can stand."""
    prior = SpeedPrior()
    assert prior.could_stand_at(0.0)  # nothing known
    for i in range(10):
        prior.update(0.1 * i, 12.0)
    braked_s = 0.9 + (12.0 - RESTART_SPEED_MPS) / 9.81
    assert not prior.could_stand_at(1.0) and not prior.could_stand_at(braked_s - 0.01)
    assert prior.could_stand_at(braked_s + 0.01)
    slow = SpeedPrior()
    slow.update(0.0, 2.5)
    assert slow.could_stand_at(0.1)
    held = SpeedPrior()  # 12 m/s measured until 0.9 s, then held until 1.9 s: braking runs from the held speed
    for i in range(10):
        held.update(0.1 * i, 12.0)
    speeds = [held.update(0.1 * i, None) for i in range(10, 20)]
    assert min(speeds) > 11.0 and not held.could_stand_at(braked_s + 0.01)
    assert held.could_stand_at(1.9 + (12.0 - RESTART_SPEED_MPS) / 9.81 + 0.01)
    prior.stop(2.0)
    assert prior.could_stand_at(2.1)
