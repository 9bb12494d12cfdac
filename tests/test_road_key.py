"""The road key frame (flowvo.odometry.road_key.RoadKeyFrame): where each step's road flow starts, when a key
frame is kept and replaced, and the road homography its next step's flow is predicted through, on exact road
points projected through a pinhole K."""

import numpy as np
import pytest

from flowvo.geometry import so3_exp
from flowvo.odometry.road_key import MAX_KEY_PREDICTION_SPEED_MPS, MAX_ROAD_KEY_S, RoadKeyFrame, RoadSpan
from flowvo.odometry.road_plane import RoadPlane
from flowvo.odometry.road_scale import road_homography
from flowvo.odometry.two_view import EssentialMotion

K = np.array([[359.0, 0.0, 303.0], [0.0, 359.0, 92.0], [0.0, 0.0, 1.0]])
HEIGHT_M = 1.5
KEY_ROAD_PX = 6.0
ROAD = np.c_[np.linspace(-3.0, 3.0, 20), np.full(20, HEIGHT_M), np.linspace(6.0, 30.0, 20)]  # 1.5 m below
LEVEL = RoadPlane.level(HEIGHT_M)  # the road under the key frame's camera (its distance is not used for a key)


def project(points: np.ndarray) -> np.ndarray:
    pixels = points @ K.T
    return pixels[:, :2] / pixels[:, 2:]


def mapped(H: np.ndarray, points_px: np.ndarray) -> np.ndarray:
    pixels = np.c_[points_px, np.ones(len(points_px))] @ H.T
    return pixels[:, :2] / pixels[:, 2:]


def forward(yaw_rad: float = 0.0) -> EssentialMotion:
    """A unit step straight forward (first camera's z) while turning ``yaw_rad`` about y."""
    R = so3_exp(np.array([0.0, yaw_rad, 0.0]))
    return EssentialMotion(R, -R @ np.array([0.0, 0.0, 1.0]), np.ones(20, bool))


def slow_step(key: RoadKeyFrame, frame: str, start_s: float, time_s: float, speed_mps: float | None = 2.0,
              road_moved_px: float = 3.0) -> RoadSpan:
    """One step from ``frame`` at ``start_s`` to ``time_s`` whose road moved ``road_moved_px`` under a trusted
    plane; its flow from the key frame where there is one."""
    span = key.begin(frame, start_s, key.frame is None)
    motion = forward()
    key.end(span, time_s, LEVEL, road_moved_px, (motion, motion), 0.2 * span.steps, speed_mps)
    return span


def test_a_step_without_a_key_frame_starts_from_its_previous_frame_unpredicted():
    key: RoadKeyFrame[str] = RoadKeyFrame(K, KEY_ROAD_PX, HEIGHT_M)
    assert key.begin("a", 0.0, True) == RoadSpan("a", 0.0, 1, False, True)
    assert key.frame is None and key.prediction is None


def test_a_step_whose_road_moved_little_keeps_its_start_frame_for_the_next_step():
    key: RoadKeyFrame[str] = RoadKeyFrame(K, KEY_ROAD_PX, HEIGHT_M)
    slow_step(key, "a", 0.0, 0.1)
    assert key.frame == "a"
    span = key.begin("b", 0.1, False)  # the next step, its flow from the key frame
    assert span == RoadSpan("a", 0.0, 2, True, False)
    assert key.frame is None and key.prediction is None  # begin hands the key over to the step


def test_a_step_whose_road_moved_enough_leaves_no_key_frame():
    key: RoadKeyFrame[str] = RoadKeyFrame(K, KEY_ROAD_PX, HEIGHT_M)
    slow_step(key, "a", 0.0, 0.1)
    slow_step(key, "b", 0.1, 0.2, road_moved_px=KEY_ROAD_PX)  # from "a": the road moved 6 px since
    assert key.frame is None and key.prediction is None  # from a key frame: the next flow is not predicted
    assert key.begin("c", 0.2, True) == RoadSpan("c", 0.2, 1, False, True)


def test_a_step_without_a_trusted_plane_leaves_no_key_frame_and_no_prediction():
    key: RoadKeyFrame[str] = RoadKeyFrame(K, KEY_ROAD_PX, HEIGHT_M)
    span = key.begin("a", 0.0, True)
    key.end(span, 0.1, None, 1.0, (forward(), forward()), None, 2.0)
    assert key.frame is None and key.prediction is None


def test_a_key_frame_is_kept_up_to_max_road_key_s_and_replaced_at_it():
    """Steps of 0.1 s whose road barely moves: the key frame at 0 s spans the steps until the one that ends
    0.5 s after it, which leaves none; the next step starts a new key frame."""
    assert MAX_ROAD_KEY_S == 0.5
    key: RoadKeyFrame[str] = RoadKeyFrame(K, KEY_ROAD_PX, HEIGHT_M)
    frames = "abcdefg"
    spans = [slow_step(key, frames[k], k / 10, (k + 1) / 10) for k in range(6)]
    assert [span.frame for span in spans] == ["a"] * 5 + ["f"]
    assert [span.steps for span in spans] == [1, 2, 3, 4, 5, 1]
    assert key.frame == "f"


def test_a_key_frames_age_does_not_depend_on_the_timestamps_last_bits():
    """A step ending at 0.49999999999999994 s (0.5 s in another container's arithmetic) replaces a key frame
    from 0 s as one ending at exactly 0.5 s does; one ending 1 ms earlier keeps it."""
    for time_s, kept in ((0.49999999999999994, False), (0.5, False), (0.499, True)):
        key: RoadKeyFrame[str] = RoadKeyFrame(K, KEY_ROAD_PX, HEIGHT_M)
        slow_step(key, "a", 0.0, 0.1)
        slow_step(key, "b", 0.1, time_s)
        assert (key.frame == "a") == kept


@pytest.mark.parametrize(("speed_mps", "predicted"),
                         [(MAX_KEY_PREDICTION_SPEED_MPS - 0.1, True), (MAX_KEY_PREDICTION_SPEED_MPS, False),
                          (None, False)])
def test_a_kept_key_frames_flow_is_predicted_only_below_the_prediction_speed(speed_mps, predicted):
    key: RoadKeyFrame[str] = RoadKeyFrame(K, KEY_ROAD_PX, HEIGHT_M)
    slow_step(key, "a", 0.0, 0.1, speed_mps=speed_mps)
    assert key.frame == "a"
    assert (key.prediction is not None) == predicted
    assert key.begin("b", 0.1, False).predicted == predicted


def test_the_predicted_homography_maps_the_key_frames_road_into_the_next_frame():
    """Two steps of 0.2 m from key frame "a", each turning 0.01 rad: the prediction for the third step maps the
    key frame's road pixels to where the road is after one more such step (constant velocity, the step's share
    of the road by the count of steps)."""
    key: RoadKeyFrame[str] = RoadKeyFrame(K, KEY_ROAD_PX, HEIGHT_M)
    step = forward(0.01)
    span = key.begin("a", 0.0, True)
    key.end(span, 0.1, LEVEL, 3.0, (step, step), 0.2, 2.0)
    span = key.begin("b", 0.1, False)
    R_key = step.R @ step.R  # a -> c, 0.4 m: the translation of the two steps chained
    t_key_m = step.R @ step.t_dir * 0.2 + step.t_dir * 0.2
    key_motion = EssentialMotion(R_key, t_key_m / np.linalg.norm(t_key_m), step.inliers)
    key.end(span, 0.2, LEVEL, 5.0, (key_motion, step), float(np.linalg.norm(t_key_m)), 2.0)
    assert key.frame == "a"
    in_next = (ROAD @ R_key.T + t_key_m) @ step.R.T + step.t_dir * np.linalg.norm(t_key_m) / 2
    np.testing.assert_allclose(mapped(key.prediction, project(ROAD)), project(in_next), atol=1e-9)


def test_a_step_from_its_previous_frame_that_found_the_road_predicts_the_next_flow_by_its_own_motion():
    """The road moved 8 px (no key frame kept): the next step's flow is predicted by this step's plane (in step
    units: 1.5 m below a 1.2 m step) and motion, which maps this step's road pixels exactly."""
    key: RoadKeyFrame[str] = RoadKeyFrame(K, KEY_ROAD_PX, HEIGHT_M)
    step = forward(0.02)
    plane = RoadPlane.level(HEIGHT_M / 1.2)
    span = key.begin("a", 0.0, True)
    key.end(span, 0.1, plane, 8.0, (step, step), 1.2, 12.0)
    assert key.frame is None
    np.testing.assert_array_equal(key.prediction, road_homography(K, step, plane))
    np.testing.assert_allclose(mapped(key.prediction, project(ROAD)), project(ROAD @ step.R.T + step.t_dir * 1.2),
                               atol=1e-9)
    assert key.begin("b", 0.1, True).predicted
