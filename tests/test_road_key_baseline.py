"""The sliding road key frame (flowvo.odometry.road_key.RoadKeyFrame.slide): where one step moves the near road
less than the baseline, the next step's road is measured from frames back, its flow predicted exactly for a level
road under constant velocity; a noisy road (a baseline given above the fixed one) slides further, and its road flow is
predicted after an unpredicted one found no plane."""

import numpy as np
import pytest

from flowvo.odometry.road_key import MAX_KEY_PREDICTION_SPEED_MPS, MAX_ROAD_KEY_S, RoadKeyFrame, RoadSpan

K = np.array([[360.0, 0.0, 310.0], [0.0, 360.0, 90.0], [0.0, 0.0, 1.0]])
HEIGHT_M = 1.65
DOWN = np.array([0.0, 1.0, 0.0])
PREDICTED = RoadSpan("previous", 0.0, 1, predicted=True, from_previous=True)  # the step's road flow, as measured
UNPREDICTED = RoadSpan("previous", 0.0, 1, predicted=False, from_previous=True)


def forward(step_m: float) -> np.ndarray:
    """T_next_prev of a step straight ahead (a point's depth falls by the step)."""
    T = np.eye(4)
    T[2, 3] = -step_m
    return T


def slid(near_px: float, frames: int, dt_s: float = 0.1, baseline_px: float = 12.0, needed_px: float | None = None,
         span: RoadSpan = PREDICTED) -> RoadKeyFrame:
    key = RoadKeyFrame(K, 6.0, HEIGHT_M, baseline_px)
    for k in range(frames):
        key.frame, key.prediction = None, None  # as RoadKeyFrame.begin leaves them for each step
        key.slide(f"frame {k}", k * dt_s, forward(0.7), DOWN, near_px, span, needed_px)
    return key


def test_a_near_road_that_moved_less_than_the_baseline_is_measured_from_as_many_steps_back_as_it_needs():
    key = slid(5.0, 6)  # 12 / 5 px: 3 steps
    assert key.frame == "frame 3"
    span = key.begin("frame 5", 0.5, from_previous=False)
    assert (span.frame, span.steps, span.predicted) == ("frame 3", 3, True)
    assert span.start_s == pytest.approx(0.3)


def test_a_near_road_that_moved_the_baseline_in_one_step_is_measured_from_the_previous_frame():
    key = slid(12.5, 6)
    assert key.frame is None and key.prediction is None


def test_without_a_trusted_plane_or_a_road_normal_no_key_frame_slides():
    key = slid(0.0, 6)  # 0: no trusted plane this step
    assert key.frame is None
    key = RoadKeyFrame(K, 6.0, HEIGHT_M, 12.0)
    for k in range(3):
        key.slide(k, k * 0.1, forward(0.7), None, 4.0, PREDICTED)
    assert key.frame is None and key.prediction is None


def test_a_refused_plane_slides_the_key_frame_only_for_a_slow_car_whose_road_moved_too_little_for_a_plane():
    key = RoadKeyFrame(K, 6.0, HEIGHT_M, 12.0)
    assert key.baseline_parallax_px(9.0, True, 20.0) == 9.0  # a trusted plane's parallax at any speed
    assert key.baseline_parallax_px(3.0, False, 1.5) == 3.0  # crawling: its road one step at a time gives no plane
    assert key.baseline_parallax_px(3.0, False, MAX_KEY_PREDICTION_SPEED_MPS) == 0.0  # too fast for a crawl
    assert key.baseline_parallax_px(6.0, False, 1.5) == 0.0  # the road moved enough: refused for another reason
    assert key.baseline_parallax_px(3.0, False, None) == 0.0  # no speed known yet


def test_a_sliding_key_frame_is_never_older_than_max_road_key_s_at_the_next_frame():
    key = slid(0.5, 12)  # 24 steps would be needed
    last_s, dt_s = 11 * 0.1, 0.1
    assert last_s + dt_s - key.begin("frame 11", last_s, from_previous=False).start_s <= MAX_ROAD_KEY_S + 1e-9
    assert key.frame is None  # begin hands the key over
    key = slid(0.5, 12)
    assert key.frame == "frame 7"  # the next frame at 1.2 s, the key at 0.7 s


def test_a_kept_key_frame_is_not_replaced_by_a_sliding_one():
    key = RoadKeyFrame(K, 6.0, HEIGHT_M, 12.0)
    key.slide("frame 0", 0.0, forward(0.7), DOWN, 5.0, PREDICTED)
    key.frame = "kept"
    key.slide("frame 1", 0.1, forward(0.7), DOWN, 5.0, PREDICTED)
    assert key.frame == "kept"


def test_forget_starts_the_sliding_key_frames_afresh():
    key = slid(5.0, 6)
    key.frame, key.prediction = None, None
    key.forget()
    key.slide("after", 0.7, forward(0.7), DOWN, 5.0, PREDICTED)
    assert key.frame is None  # one frame only: nothing to slide back to


def test_the_prediction_maps_a_level_roads_points_from_the_key_frame_into_the_next_frame_exactly():
    """Steps of 0.7 m straight ahead, the road 1.65 m below: the key frame 3 steps before the next frame; the
    homography takes each road point's pixel in the key frame to its pixel 2.1 m further on."""
    key = slid(5.0, 6)
    road = np.array([[-1.0, HEIGHT_M, 8.0], [0.5, HEIGHT_M, 12.0], [1.2, HEIGHT_M, 20.0]])
    seen = road @ K.T
    moved = (road - [0.0, 0.0, 2.1]) @ K.T
    mapped = np.c_[seen[:, :2] / seen[:, 2:], np.ones(3)] @ key.prediction.T
    np.testing.assert_allclose(mapped[:, :2] / mapped[:, 2:], moved[:, :2] / moved[:, 2:], atol=1e-9)


def test_a_noisy_road_is_measured_over_the_baseline_it_needs():
    key = slid(5.0, 6, needed_px=20.0)  # 20 / 5 px: 4 steps, where the fixed 12 px take 3
    assert key.frame == "frame 2"
    assert slid(12.5, 6, needed_px=20.0).frame == "frame 4"  # one step is not enough for it either
    assert slid(12.5, 6, needed_px=None).frame is None


def test_a_noisy_roads_flow_is_predicted_one_step_ahead_after_an_unpredicted_one_found_no_plane():
    """No trusted plane (0 px) from a flow measured without a prediction: the next step's flow from this frame is
    predicted for the road's normal under this step's motion again, exactly for a level road."""
    key = slid(0.0, 3, needed_px=20.0, span=UNPREDICTED)
    assert key.frame is None and key.prediction is not None
    road = np.array([[-1.0, HEIGHT_M, 8.0], [0.5, HEIGHT_M, 12.0], [1.2, HEIGHT_M, 20.0]])
    seen = road @ K.T
    moved = (road - [0.0, 0.0, 0.7]) @ K.T
    mapped = np.c_[seen[:, :2] / seen[:, 2:], np.ones(3)] @ key.prediction.T
    np.testing.assert_allclose(mapped[:, :2] / mapped[:, 2:], moved[:, :2] / moved[:, 2:], atol=1e-9)


@pytest.mark.parametrize("needed_px, span", [(None, UNPREDICTED), (12.0, UNPREDICTED), (20.0, PREDICTED)])
def test_no_prediction_after_a_missed_road_that_needs_only_the_fixed_baseline_or_was_predicted(needed_px, span):
    key = slid(0.0, 3, needed_px=needed_px, span=span)
    assert key.frame is None and key.prediction is None
