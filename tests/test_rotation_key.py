"""Rotations measured from a key frame up to 0.1 s back at frame rates above 10 Hz (flowvo.odometry.rotation_key), the
direction of travel under a given rotation (two_view.direction_given_rotation), and the default method taking
a 30 frames/s step's rotation from its key frame, on exact correspondences."""

import numpy as np
import pytest

from flowvo.camera import Camera, CameraIntrinsics
from flowvo.geometry import so3_exp
from flowvo.methods.flowvo import FlowGeometryStep, GeometryFlow, GeometryFrame
from flowvo.odometry.rotation_key import RotationKeyFrame
from flowvo.odometry.two_view import direction_given_rotation

HW = (188, 620)
CAMERA = Camera(CameraIntrinsics(359.0, 359.0, 303.0, 92.0), height_m=1.5)
K = CAMERA.intrinsics.K
EMPTY = np.zeros((0, 2), np.float32)
SCENE = np.c_[np.random.default_rng(7).uniform(-15, 15, 300), np.random.default_rng(8).uniform(-5, 1.0, 300),
              np.random.default_rng(9).uniform(8, 50, 300)]


def project(points, dtype=np.float32):
    pixels = points @ K.T
    return (pixels[:, :2] / pixels[:, 2:]).astype(dtype)


def unit(vector):
    vector = np.asarray(vector, dtype=float)
    return vector / np.linalg.norm(vector)


def test_the_direction_under_the_true_rotation_comes_back_exactly_with_its_sign():
    R = so3_exp(np.array([0.01, -0.02, 0.005]))
    t = -R @ unit([0.1, -0.05, 1.0]) * 1.3
    points_prev, points_next = project(SCENE, np.float64), project(SCENE @ R.T + t, np.float64)
    near = so3_exp(np.array([0.0, 0.17, 0.0])) @ unit(t)  # 10 degrees off: it only scales the residuals
    np.testing.assert_allclose(direction_given_rotation(points_prev, points_next, K, R, near), unit(t), atol=1e-9)
    np.testing.assert_allclose(direction_given_rotation(points_prev, points_next, K, R, -near), -unit(t), atol=1e-9)


def key_frames_seen(times_s):
    """The key frame each step starts from (None: the previous frame) over frames named by their index."""
    key, seen = RotationKeyFrame(), []
    for k in range(1, len(times_s)):
        seen.append(key.frame)
        key.advance((times_s[k - 1], k - 1), times_s[k], np.eye(3))
    return seen


def test_at_30_frames_per_second_a_key_frame_spans_three_steps():
    assert key_frames_seen(np.arange(10) / 30) == [None, 0, 0, None, 3, 3, None, 6, 6]


def test_at_10_frames_per_second_with_kittis_jitter_every_step_starts_from_the_previous_frame():
    times_s = np.cumsum(np.r_[0.0, np.random.default_rng(3).uniform(0.0985, 0.1045, 30)])  # KITTI: 0.1035-0.1045
    assert key_frames_seen(times_s) == [None] * 30


def test_step_rotations_from_a_key_frame_chain_to_the_key_frames_fitted_rotations():
    """The steps a -> b, b -> c, c -> d of a key frame a: each step's rotation is the key frame's rotation to its
    frame after the one to the previous frame, so the chain ends at the fitted rotation a -> d exactly, whatever
    the first step's rotation was."""
    key = RotationKeyFrame()
    R_ab = so3_exp(np.array([0.002, 0.011, 0.0]))
    R_ac, R_ad = so3_exp(np.array([0.001, 0.019, 0.001])), so3_exp(np.array([0.003, 0.031, -0.001]))
    key.advance((0.0, "a"), 1 / 30, R_ab)
    R_bc = key.step_rotation(R_ac)
    key.advance((1 / 30, "b"), 2 / 30, R_bc)
    R_cd = key.step_rotation(R_ad)
    np.testing.assert_allclose(R_cd @ R_bc @ R_ab, R_ad, atol=1e-12)
    key.advance((2 / 30, "c"), 3 / 30, R_cd)
    assert key.frame is None  # 0.1 s old: the next step starts from d


PITCH_ERROR = so3_exp(np.array([np.radians(0.05), 0.0, 0.0]))  # each pair's tracks: a rotation 0.05 degrees off


def thirty_fps_steps(key_yaw_error_deg=0.0):
    """Frames 0..3 at 30 frames/s of a camera turning 0.01 rad and moving 0.4 m a step: the default method's motions
    (T_prev_cur) when every pair's tracks fit a rotation 0.05 degrees off and the tracks from the key frame,
    frame 0, are exact but for a yaw ``key_yaw_error_deg`` off."""
    step = FlowGeometryStep(CAMERA, HW)
    key_rotation_error = so3_exp(np.array([0.0, np.radians(key_yaw_error_deg), 0.0]))
    R_step, t_step = so3_exp(np.array([0.0, 0.01, 0.0])), -np.array([0.0, 0.0, 0.4])
    scenes = [SCENE]
    for _ in range(3):
        scenes.append(scenes[-1] @ R_step.T + R_step @ t_step)
    rays = np.c_[step.road.grid_undistorted_px, np.ones(len(step.road.grid_px))] @ np.linalg.inv(step.K).T
    road = rays * (step.camera.camera_height_m / rays[:, 1:2])
    frames = [GeometryFrame(np.zeros(HW, np.uint8), *(EMPTY,) * 5, None) for _ in scenes]
    motions = []
    for k in range(1, 4):
        key = (None, None) if step.checks.rotation_key.frame is None else \
            (project(SCENE), project(scenes[k] @ key_rotation_error.T))
        assert step.checks.rotation_key.frame is (None if k == 1 else frames[0])
        motion = project(scenes[k - 1]), project(scenes[k] @ PITCH_ERROR.T)
        flow = GeometryFlow(*motion, step.fit_motion(*motion), step.road.grid_undistorted_px,
                            project(road @ R_step.T + R_step @ t_step), frames[k], rotation_key_prev=key[0],
                            rotation_key_next=key[1])
        motions.append(step.motion(((k - 1) / 30, k / 30), frames[k - 1], flow))
    return motions, np.linalg.matrix_power(R_step, 3), step.summary()["rotation_key_steps"]


def angle_deg(R_a, R_b):
    return np.degrees(np.arccos(np.clip((np.trace(R_a @ R_b.T) - 1) / 2, -1.0, 1.0)))


def test_at_30_frames_per_second_the_rotation_over_a_key_frames_span_does_not_add_up_the_pairs_errors():
    motions, R_03, key_steps = thirty_fps_steps()
    assert key_steps == 2
    chained = motions[0] @ motions[1] @ motions[2]  # T_0_3: its rotation is R_03 transposed
    assert angle_deg(chained[:3, :3].T, R_03) < 1e-4  # float32 tracks; the pairs alone: 0.15 degrees


def test_a_key_frames_rotation_far_off_the_pairs_is_not_taken():
    motions, R_03, key_steps = thirty_fps_steps(key_yaw_error_deg=1.0)
    assert key_steps == 0
    chained = motions[0] @ motions[1] @ motions[2]
    assert angle_deg(chained[:3, :3].T, R_03) == pytest.approx(0.15, abs=0.01)  # the pairs' three errors
