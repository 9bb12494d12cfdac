"""The default method's branches on exact correspondences: road scale, standstill, degenerate geometry, the
network fallback, the road key frame; and its policies (fallback after a second, speed window in seconds)."""

import dataclasses
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from flowvo.camera import Camera, CameraIntrinsics
from flowvo.geometry import so3_exp
from flowvo.methods.flowvo import FlowGeometryStep, GeometryFlow, GeometryFrame
from flowvo.odometry.road_normal import FIT_REFERENCE_DEPTH, RoadNormal
from flowvo.odometry.road_plane import RoadPlane
from flowvo.odometry.road_scale import (
    NetworkFallbackPolicy,
    onward_road_homography,
    road_flow_within_reach,
    road_homography,
    trusted_road_plane,
)
from flowvo.odometry.scale_window import ScaleWindow
from flowvo.odometry.speed_prior import SpeedPrior
from flowvo.odometry.two_view import EssentialMotion

HW = (188, 620)
CAMERA = Camera(CameraIntrinsics(359.0, 359.0, 303.0, 92.0), height_m=1.5)
EMPTY = np.zeros((0, 2), np.float32)


def project(K, points):
    pixels = points @ K.T
    return (pixels[:, :2] / pixels[:, 2:]).astype(np.float32)


def step_flow(step, step_m, yaw_rad=0.01, scene_moves=True, direction=(0.0, 0.0, 1.0)):
    """Exact tracks and road correspondences of a camera moving ``step_m`` along ``direction`` (its own frame;
    a car: forward) while turning."""
    rng = np.random.default_rng(5)
    scene = np.c_[rng.uniform(-15, 15, 300), rng.uniform(-5, 1.0, 300), rng.uniform(8, 50, 300)]
    R = so3_exp(np.array([0.0, yaw_rad, 0.0]))
    t = -R @ (step_m * np.asarray(direction))
    rays = np.c_[step.road.grid_undistorted_px, np.ones(len(step.road.grid_px))] @ np.linalg.inv(step.K).T
    road = rays * (step.camera.camera_height_m / rays[:, 1:2])  # the grid's rays hit the road plane y = height
    frame = untracked_frame()
    moved = (lambda x: x @ R.T + t) if scene_moves else (lambda x: x)
    return tracked_flow(step, project(step.K, scene), project(step.K, moved(scene)), step.road.grid_undistorted_px,
                        project(step.K, moved(road)), frame)


def untracked_frame():
    """A working frame without tracks (the first of a drive)."""
    return GeometryFrame(np.zeros(HW, np.uint8), EMPTY, EMPTY, EMPTY, EMPTY, EMPTY, None)


def tracked_flow(step, motion_prev, motion_next, road_prev, road_next, frame, **keys):
    """The step's flow with the step's essential fit of the tracks ``motion_prev`` -> ``motion_next``."""
    return GeometryFlow(motion_prev, motion_next, step.fit_motion(motion_prev, motion_next), road_prev, road_next,
                        frame, **keys)


def fallback_network(step, distance_m):
    calls = []
    network = SimpleNamespace(network=SimpleNamespace(stack=1), working_hw=step.working_hw,
                              distance_m=lambda previous, current: calls.append(1) or distance_m)
    return network, calls


def test_road_plane_at_the_camera_height_gives_the_metric_step():
    step = FlowGeometryStep(CAMERA, HW)
    motion = step.motion((0.0, 0.1), None, step_flow(step, 1.2))
    assert np.linalg.norm(motion[:3, 3]) == pytest.approx(1.2, rel=1e-4)
    assert motion[2, 3] > 0  # forward


def test_a_still_road_and_scene_is_a_standstill():
    step = FlowGeometryStep(CAMERA, HW)
    np.testing.assert_array_equal(step.motion((0.0, 0.1), None, step_flow(step, 0.0, 0.0, False)), np.eye(4))


@pytest.mark.parametrize(("dt_s", "still"), [(0.1, True), (1 / 30, False)])
def test_under_half_a_pixel_in_a_tenth_of_a_second_stands_still_and_faster_frames_creep(dt_s, still):
    """A 5 cm step turning 0.01 degrees moves the road 0.38 px and the scene 0.2 px (medians). In 0.1 s that is a
    standstill; at 30 frames/s it is a car at 1.5 m/s (under half a pixel a 10 Hz step, over it in 0.1 s):
    not stopped, taken straight ahead and unturned (its tracks moved too little for an essential fit)."""
    step = FlowGeometryStep(CAMERA, HW)
    motion = step.motion((0.0, dt_s), None, step_flow(step, 0.05, yaw_rad=0.0002))
    fit = step.last_view[2]
    if still:
        assert fit is None
        np.testing.assert_array_equal(motion, np.eye(4))
    else:
        np.testing.assert_array_equal(fit.R, np.eye(3))
        np.testing.assert_array_equal(fit.t_dir, [0.0, 0.0, -1.0])  # the camera's forward axis, level


def test_a_still_view_at_speed_keeps_the_last_motion_until_the_car_could_have_braked():
    """12 m/s on a road, then images that stand still (past a crest only distant scenery is in view): the
    car keeps its motion, and stands still once 1 g of braking could have stopped it (a camera at KITTI's height:
    the method's limits act in camera heights)."""
    step = FlowGeometryStep(Camera(CAMERA.intrinsics, height_m=1.65), HW)
    moving = step.motion((0.0, 0.1), None, step_flow(step, 1.2))
    still = step_flow(step, 0.0, 0.0, False)
    np.testing.assert_array_equal(step.motion((0.1, 0.2), None, still), moving)
    np.testing.assert_array_equal(step.motion((0.9, 1.0), None, still), moving)  # 8.8 m/s of braking since 0.1 s
    np.testing.assert_array_equal(step.motion((1.0, 1.1), None, still), np.eye(4))  # 9.8 m/s: down to 2.2


LEFT, RIGHT = (-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)  # sideways, in the camera's frame


@pytest.mark.parametrize(("step_m", "side", "refused_by"), [(1.0, LEFT, "direction_kept_steps"), (0.3, LEFT, None),
                                                            (0.3, RIGHT, "direction_against_turn_steps")])
def test_a_fitted_direction_no_car_can_take_gives_way_to_the_last_one(step_m, side, refused_by):
    """A step forward, then tracks that move as if the camera had slid sideways while turning left. Slid left at
    10 m/s (further off its axis than a car at speed travels), or right at any speed (against its turn), the
    direction of travel stays the last one; slid left at 3 m/s (a camera swinging in a slow turn) the fit's motion is
    taken. The run counts the step by the check that refused it."""
    step = FlowGeometryStep(CAMERA, HW)
    step.motion((0.0, 0.1), None, step_flow(step, step_m))
    sideways = step.motion((0.1, 0.2), None, step_flow(step, step_m, yaw_rad=0.02, direction=side))
    travel = sideways[:3, 3] / np.linalg.norm(sideways[:3, 3])
    np.testing.assert_allclose(travel, side if refused_by is None else [0.0, 0.0, 1.0], atol=1e-4)
    if refused_by is None:
        np.testing.assert_allclose(sideways[:3, :3], so3_exp(np.array([0.0, 0.02, 0.0])).T, atol=1e-4)
    counts = step.summary()
    assert [name for name in ("direction_kept_steps", "direction_against_turn_steps") if counts[name]] == \
        ([] if refused_by is None else [refused_by])


WRONG_R = so3_exp(np.array([0.0, 0.03, 0.0]))  # a sideways fit's rotation, 0.6 degrees off a 0.02 rad turn (a yaw
# rate that no yaw rate check refuses after the first step's)


def at_speed_with_sideways_fits(monkeypatch):
    """A step after a forward 1 m step at 10 m/s turning 0.02 rad whose essential fits from now on come back
    sideways, to the left it turns to (every track an inlier), with rotation ``WRONG_R``."""
    step = FlowGeometryStep(CAMERA, HW)
    step.motion((0.0, 0.1), None, step_flow(step, 1.0, yaw_rad=0.02))

    def sideways_fit(points_prev, points_next, K, threshold_px, robust_scale_px=None):
        return EssentialMotion(WRONG_R, -WRONG_R @ np.array(LEFT), np.ones(len(points_prev), bool))

    monkeypatch.setattr("flowvo.methods.flowvo.essential_motion", sideways_fit)
    return step


def test_a_refused_direction_takes_the_rotation_the_tracks_give_along_the_last_direction(monkeypatch):
    """At 10 m/s the fit of a forward step turning 0.02 rad comes back sideways with its rotation 0.6 degrees
    off (as past a crest): the step goes forward, with the rotation the tracks give along that direction."""
    step = at_speed_with_sideways_fits(monkeypatch)
    turned = step.motion((0.1, 0.2), None, step_flow(step, 1.0, yaw_rad=0.02))
    np.testing.assert_allclose(turned[:3, :3], so3_exp(np.array([0.0, 0.02, 0.0])).T, atol=1e-6)  # float32 tracks
    np.testing.assert_allclose(turned[:3, 3] / np.linalg.norm(turned[:3, 3]), [0.0, 0.0, 1.0], atol=1e-6)
    assert step.summary()["direction_kept_steps"] == 1


def test_a_fit_whose_yaw_rate_jumps_takes_the_last_yaw_rate_and_its_direction_from_the_tracks(monkeypatch):
    """At 3 m/s (no direction check) a step turning 0.01 rad, then one whose fit turns 0.04 rad (1.7 degrees more
    in 0.1 s, as a failed fit at low speed): the step takes the last yaw rate and the direction its tracks give
    under it; the run counts the step."""
    step = FlowGeometryStep(CAMERA, HW)
    step.motion((0.0, 0.1), None, step_flow(step, 0.3))
    overturned = so3_exp(np.array([0.0, 0.04, 0.0]))
    monkeypatch.setattr("flowvo.methods.flowvo.essential_motion", lambda points_prev, points_next, K, threshold_px,
                        robust_scale_px=None:
                        EssentialMotion(overturned, np.array([0.0, 0.0, -1.0]), np.ones(len(points_prev), bool)))
    gated = step.motion((0.1, 0.2), None, step_flow(step, 0.3))
    np.testing.assert_allclose(gated[:3, :3], so3_exp(np.array([0.0, 0.01, 0.0])).T, atol=1e-6)
    np.testing.assert_allclose(gated[:3, 3] / np.linalg.norm(gated[:3, 3]), [0.0, 0.0, 1.0], atol=1e-5)
    assert step.summary()["yaw_refused_steps"] == 1


def test_a_refused_direction_keeps_the_fits_rotation_where_no_rotation_along_the_last_direction_fits(monkeypatch):
    """At 10 m/s a sideways fit of tracks that no motion explains (each moved at random): the step goes
    forward with the fit's rotation."""
    step = at_speed_with_sideways_fits(monkeypatch)
    flow = step_flow(step, 1.0)
    scattered = flow.motion_prev + np.random.default_rng(0).uniform(-20, 20, flow.motion_prev.shape).astype(np.float32)
    kept = step.motion((0.1, 0.2), None, dataclasses.replace(flow, motion_next=scattered,
                                                            motion_fit=step.fit_motion(flow.motion_prev, scattered)))
    np.testing.assert_allclose(kept[:3, :3], WRONG_R.T, atol=1e-12)
    np.testing.assert_allclose(kept[:3, 3] / np.linalg.norm(kept[:3, 3]), [0.0, 0.0, 1.0], atol=1e-9)


def test_too_few_tracks_keep_the_last_motion():
    step = FlowGeometryStep(CAMERA, HW)
    first = step.motion((0.0, 0.1), None, step_flow(step, 1.0))
    flow = step_flow(step, 1.0)
    degenerate = tracked_flow(step, flow.motion_prev[:10], flow.motion_next[:10], flow.road_prev, flow.road_next,
                              flow.current)
    np.testing.assert_array_equal(step.motion((0.1, 0.2), None, degenerate), first)


def test_without_a_trusted_road_the_network_measures_after_a_second():
    probe = FlowGeometryStep(CAMERA, HW)
    network, calls = fallback_network(probe, 2.0)
    step = FlowGeometryStep(CAMERA, HW, fallback=network)
    step.motion((0.0, 0.1), None, step_flow(step, 1.0))  # a road: 10 m/s
    flow = step_flow(step, 1.0)
    no_road = dataclasses.replace(flow, road_prev=flow.road_prev[:5], road_next=flow.road_next[:5])
    times = np.arange(0.1, 1.6, 0.1)
    lengths = [np.linalg.norm(step.motion((t, t + 0.1), flow.current, no_road)[:3, 3]) for t in times]
    assert len(calls) == 5 and step.summary()["network_distance_steps"] == 5  # after 1 s: t + 0.1 > 1.1
    assert step.summary()["road_planes"] == {"trusted": 1, "refused_as_tilted": 0,
                                             "candidates_median_pitch_deg": None, "candidates_median_roll_deg": None,
                                             "candidates_pitch_spread_deg": None, "ground_cells_off_road": 0,
                                             "far_road_off_plane_share": None,
                                             "pitches_taken_deg": [], "rolls_taken_deg": [],
                                             "road_flow_error_px": 0.0, "road_flow_error_px_largest": 0.0,
                                             "road_baseline_px_largest": 12.0}  # an exact flow: the fixed baseline
    assert lengths[0] == pytest.approx(1.0, rel=1e-4) and lengths[-1] > 1.0  # the prior, then the network's 2 m pull


def test_while_the_drives_mounting_is_pending_the_network_waits_for_the_road():
    """Planes refused as tilted at a drive's start (a camera pitched down, told level) are the road seen through a
    mounting not taken yet: no network distance then, however long no plane is trusted; once the mounting is
    judged (here: as many planes trusted as refused), the network steps in after its second as before."""
    probe = FlowGeometryStep(CAMERA, HW)
    network, calls = fallback_network(probe, 2.0)
    step = FlowGeometryStep(CAMERA, HW, fallback=network)
    step.road_length.tally.refused_as_tilted = 5  # the drive's first candidate planes, refused as tilted
    flow = step_flow(step, 1.0)
    no_road = dataclasses.replace(flow, road_prev=flow.road_prev[:5], road_next=flow.road_next[:5])
    for t in np.arange(0.0, 1.5, 0.1):
        step.motion((t, t + 0.1), flow.current, no_road)
    assert calls == [] and step.summary()["network_distance_steps"] == 0
    step.road_length.tally.trusted = 5  # no longer most of them refused: not pending
    for k in range(15, 24):  # within a second of the road last seen (steps ending at 1.6 .. 2.4 s)
        step.motion((k / 10, (k + 1) / 10), flow.current, no_road)
    assert calls == []
    for k in range(24, 28):  # past it
        step.motion((k / 10, (k + 1) / 10), flow.current, no_road)
    assert len(calls) == 3  # the steps ending at 2.6, 2.7 and 2.8 s


def test_a_slowly_moving_road_keeps_its_key_frame_and_scales_the_step_by_time():
    step = FlowGeometryStep(CAMERA, HW)
    previous = untracked_frame()
    slow = step_flow(step, 0.2)  # a small road motion: under the key frame threshold
    assert np.linalg.norm(step.motion((0.0, 0.1), previous, slow)[:3, 3]) == pytest.approx(0.2, rel=1e-4)
    assert step.road_key.frame is previous  # the next step measures from the same frame
    fast = step_flow(step, 1.0)
    step.motion((0.1, 0.2), previous, fast)
    assert step.road_key.frame is None  # the road moved enough: the next step starts from this frame


@pytest.mark.parametrize(("dt_s", "predicted"), [(0.1, True), (0.02, False)])
def test_a_kept_key_frame_predicts_the_next_road_flow_only_below_6_mps(dt_s, predicted):
    """Steps of 0.2 m keep their road key frame. At 2 m/s (10 Hz) the next step's road flow from it is
    predicted at constant velocity; at 10 m/s (50 Hz) it is not (a car that fast whose road barely moves in
    view has lost it)."""
    step = FlowGeometryStep(CAMERA, HW)
    previous = untracked_frame()
    for k in range(2):
        step.motion((k * dt_s, (k + 1) * dt_s), previous, step_flow(step, 0.2))
    assert step.road_key.frame is previous
    assert (step.road_key.prediction is not None) == predicted


def test_onward_road_homography_maps_the_key_frames_road_into_the_next_frame_exactly():
    K = CAMERA.K
    road = np.c_[np.linspace(-3, 3, 20), np.full(20, 1.5), np.linspace(6, 30, 20)]  # 1.5 m below the key camera
    R_key = so3_exp(np.array([0.002, 0.03, -0.001]))  # key frame -> current frame, 0.5 m
    key = EssentialMotion(R_key, -R_key @ np.array([0.05, 0.0, 1.0]) / np.hypot(0.05, 1.0), np.ones(20, bool))
    R_step = so3_exp(np.array([0.0, 0.02, 0.0]))  # the current step, 0.3 m, taken once more
    step_motion = EssentialMotion(R_step, -R_step @ np.array([0.0, 0.0, 1.0]), np.ones(20, bool))
    H = onward_road_homography(K, SimpleNamespace(normal=np.array([0.0, 1.0, 0.0])), key, 0.5, step_motion, 0.3,
                               1.5)
    in_next = (road @ R_key.T + key.t_dir * 0.5) @ R_step.T + step_motion.t_dir * 0.3
    mapped = np.c_[project(K, road), np.ones(20)] @ H.T
    np.testing.assert_allclose(mapped[:, :2] / mapped[:, 2:], project(K, in_next), atol=1e-3)  # float32 pixels


def test_the_window_measures_each_step_against_the_last_through_the_continued_tracks():
    """Three frames a, b, c of exact tracks: the step b -> c gets its road length and, from the tracks of
    a -> b that went on into c (rows of b's tracks), the ratio of its length to a -> b's."""
    step = FlowGeometryStep(CAMERA, HW, window=ScaleWindow())
    rng = np.random.default_rng(5)
    scene_a = np.c_[rng.uniform(-15, 15, 300), rng.uniform(-5, 1.0, 300), rng.uniform(8, 50, 300)]
    moves = [(0.01, 0.8), (0.005, 1.1)]  # (yaw rad, metres) of a -> b and b -> c
    scenes = [scene_a]
    for yaw, length in moves:
        R = so3_exp(np.array([0.0, yaw, 0.0]))
        scenes.append(scenes[-1] @ R.T - R @ np.array([0.0, 0.0, length]))
    a, b, c = (project(step.K, scene) for scene in scenes)
    rows = np.arange(0, 300, 6)
    frame_b = GeometryFrame(np.zeros(HW, np.uint8), EMPTY, a, b, a, b, None)
    frame_c = GeometryFrame(np.zeros(HW, np.uint8), EMPTY, b, c, b, c, None, rows, c[rows])
    road_ab, road_bc = step_flow(step, 0.8, 0.01), step_flow(step, 1.1, 0.005)
    step.motion((0.0, 0.1), None, tracked_flow(step, a, b, road_ab.road_prev, road_ab.road_next, frame_b))
    unit_m = step.metres_per_unit  # the window measures in KITTI camera heights
    assert step._step_scale.ratio is None and step._step_scale.road_m * unit_m == pytest.approx(0.8, rel=1e-4)
    step.motion((0.1, 0.2), frame_b, tracked_flow(step, b, c, road_bc.road_prev, road_bc.road_next, frame_c))
    assert step._step_scale.ratio == pytest.approx(1.1 / 0.8, rel=1e-6)
    assert step._step_scale.road_m * unit_m == pytest.approx(1.1, rel=1e-4)


def test_network_fallback_policy_counts_only_after_its_horizon():
    policy = NetworkFallbackPolicy(after_s=1.0)
    assert policy.network_needed(0.5)  # nothing seen yet
    policy.road_seen(1.0)
    assert not policy.network_needed(1.9) and not policy.network_needed(2.0)
    assert policy.network_needed(2.05) and policy.network_steps == 2


def test_road_homography_maps_road_points_exactly():
    K = CAMERA.K
    R = so3_exp(np.array([0.0, 0.03, 0.0]))
    t_dir = -R @ np.array([0.0, 0.0, 1.0])
    road = np.c_[np.linspace(-3, 3, 20), np.full(20, 1.5), np.linspace(6, 30, 20)]  # y = 1.5 m below
    plane = SimpleNamespace(normal=np.array([0.0, 1.0, 0.0]), distance=1.5 / 1.3)  # step 1.3 m, in step units
    H = road_homography(K, EssentialMotion(R, t_dir, np.ones(20, bool)), plane)
    before, after = project(K, road), project(K, road @ R.T + t_dir * 1.3)
    mapped = np.c_[before, np.ones(20)] @ H.T
    np.testing.assert_allclose(mapped[:, :2] / mapped[:, 2:], after, atol=1e-3)


@pytest.mark.parametrize("predicted_m", [None, 1.0, 1.05])
def test_road_flow_of_an_exactly_moved_road_gives_its_step_length(predicted_m):
    """A textured frame moved by the homography of a flat road under a 1 m step and a 1 degree turn: the
    road flow (without a prediction, with the exact one, with one 5 % too long) and the exact motion give
    the step length from the road plane within 1 % (DIS leaves part of a mispredicted residual unmeasured,
    at most a fifth, measured), once the nearest road points that left the frame are dropped."""
    step = FlowGeometryStep(CAMERA, HW)
    R = so3_exp(np.array([0.0, np.radians(1.0), 0.0]))
    motion = EssentialMotion(R, -R @ np.array([0.0, 0.0, 1.0]), np.ones(1, bool))
    previous, current = _road_moved(step, motion, 1.0, seed=3)
    road = step.road.measure(previous, current,
                             None if predicted_m is None else _road_homography_of(step, motion, predicted_m))
    assert len(road[0]) < len(step.road.grid_px)  # the nearest road points left the frame
    plane = trusted_road_plane(*road, step.K, motion)
    assert CAMERA.height_m / plane.distance == pytest.approx(1.0, rel=0.01)


def test_the_best_prediction_of_an_exactly_moved_road_is_its_step():
    """A textured frame moved by a flat road's homography under a 3 m step: among road predictions at steps 12 %
    apart, the one whose warp matches the road is the true step's (how a drive that starts fast finds its road)."""
    step = FlowGeometryStep(CAMERA, HW)
    motion = EssentialMotion(np.eye(3), np.array([0.0, 0.0, -1.0]), np.ones(1, bool))
    predictions = [_road_homography_of(step, motion, length_m) for length_m in 3.0 * 1.12 ** np.arange(-6, 7)]
    assert step.road.best_prediction(*_road_moved(step, motion, 3.0, seed=4), predictions) is predictions[6]


def _road_homography_of(step: FlowGeometryStep, motion: EssentialMotion, length_m: float) -> np.ndarray:
    """The homography of a level road ``CAMERA.height_m`` below the camera under ``motion`` at ``length_m``."""
    return road_homography(step.K, motion, RoadPlane.level(CAMERA.height_m / length_m))


def _road_moved(step: FlowGeometryStep, motion: EssentialMotion, length_m: float, seed: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """A blurred random texture of ``HW`` and the same moved by the level road's homography under ``motion`` at
    ``length_m``, both uint8."""
    texture = np.random.default_rng(seed).uniform(0, 255, (HW[0] // 2, HW[1] // 2)).astype(np.float32)
    previous = cv2.GaussianBlur(cv2.resize(texture, HW[::-1], interpolation=cv2.INTER_CUBIC), (0, 0), 1.0)
    current = cv2.warpPerspective(previous, _road_homography_of(step, motion, length_m), HW[::-1],
                                  flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    return previous.clip(0, 255).astype(np.uint8), current.clip(0, 255).astype(np.uint8)


@pytest.mark.parametrize(("rate_hz", "window"), [(5.0, 9), (10.0, 9), (30.0, 27)])
def test_speed_window_spans_the_same_time_at_any_frame_rate(rate_hz, window):
    prior = SpeedPrior()
    for k in range(60):
        prior.update(k / rate_hz, 10.0)
    assert prior._history.maxlen == window


def _plane_through(centre: np.ndarray, normal: np.ndarray) -> RoadPlane:
    """The road plane through ``centre`` (camera frame) with unit ``normal``."""
    return RoadPlane(float(normal @ centre), normal, 0.5, centre)


def _pitched(pitch_rad: float) -> np.ndarray:
    """The camera's down axis pitched by ``pitch_rad`` about x."""
    return np.array([0.0, np.cos(pitch_rad), np.sin(pitch_rad)])


def _pitch_rad(plane: RoadPlane) -> float:
    return float(np.arctan2(plane.normal[2], plane.normal[1]))


def test_a_road_normal_blends_each_plane_by_the_variances_and_takes_the_distance_through_its_centre():
    road = RoadNormal(fit_sigma_rad=0.005, drift_rad=0.0035)
    near = np.array([0.0, 1.0, FIT_REFERENCE_DEPTH])  # the road's centre 7.4 step lengths ahead, 1 below
    first = road.smoothed(_plane_through(near, _pitched(0.0)), np.eye(3))
    assert first.distance == pytest.approx(1.0) and road.variance == pytest.approx(0.005**2)  # the plane as fitted
    road.advance(np.eye(3), 0.1)
    carried = 0.005**2 + 0.0035**2 * 0.1
    gain = carried / (carried + 0.005**2)
    tilted = road.smoothed(_plane_through(near, _pitched(np.radians(1.0))), np.eye(3))  # one fit pitched by 1 degree
    assert _pitch_rad(tilted) == pytest.approx(gain * np.radians(1.0), rel=1e-3)
    assert tilted.distance == pytest.approx(float(tilted.normal @ near))
    assert road.variance == pytest.approx((1 - gain) * carried)
    road.advance(np.eye(3), 0.1)
    far_centre = np.array([0.0, 1.0, 5 * FIT_REFERENCE_DEPTH])
    far = road.smoothed(_plane_through(far_centre, _pitched(np.radians(1.0))), np.eye(3))
    assert abs(_pitch_rad(far) - _pitch_rad(tilted)) < 0.01 * np.radians(1.0)  # 5x the depth: 625x the variance


def test_one_steps_road_flow_is_within_reach_by_its_near_road_a_spans_by_its_median_point():
    far_to_near = np.linspace(2.0, 20.0, 100)  # road points' motions (px): the near road moves most
    assert np.median(far_to_near) < 12.0 <= np.percentile(far_to_near, 90)
    assert not road_flow_within_reach(far_to_near, 12.0, predicted=False)  # the near road was beyond DIS's reach
    assert road_flow_within_reach(far_to_near, 12.0, predicted=True)  # DIS measured only what the prediction missed
    assert road_flow_within_reach(far_to_near / 2, 12.0, predicted=False)
    assert not road_flow_within_reach(np.zeros(0), 12.0, predicted=False)
    assert road_flow_within_reach(far_to_near, 12.0, predicted=False, steps=2)  # a key frame's span: the median
    assert not road_flow_within_reach(far_to_near * 2, 12.0, predicted=False, steps=2)


def test_the_road_normal_is_carried_by_the_camera_rotation_and_kept_only_from_predicted_road():
    road = RoadNormal()
    centre = np.array([0.0, 1.0, FIT_REFERENCE_DEPTH])
    road.smoothed(_plane_through(centre, _pitched(0.0)), np.eye(3))
    pitch = so3_exp(np.array([np.radians(2.0), 0.0, 0.0]))  # the camera pitches: the road turns the other way
    road.advance(pitch, 0.1)
    seen = pitch @ np.array([0.0, 1.0, 0.0])
    np.testing.assert_allclose(road.normal, seen)
    plane = road.smoothed(_plane_through(centre, seen), np.eye(3))  # the same road, measured
    np.testing.assert_allclose(plane.normal, seen, atol=1e-12)
    key_rotation = so3_exp(np.array([0.0, np.radians(3.0), 0.0]))  # a plane measured in an earlier key frame
    in_key = road.smoothed(_plane_through(centre, key_rotation.T @ seen), key_rotation)
    np.testing.assert_allclose(in_key.normal, key_rotation.T @ seen, atol=1e-12)
    kept, variance = road.normal.copy(), road.variance
    unpredicted = road.smoothed(_plane_through(centre, _pitched(np.radians(3.0))), np.eye(3), keep=False)
    assert _pitch_rad(plane) < _pitch_rad(unpredicted) < np.radians(3.0)  # blended, between the two
    np.testing.assert_array_equal(road.normal, kept)
    assert road.variance == variance
    road.forget()
    assert road.normal is None
