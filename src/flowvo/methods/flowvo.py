"""``flowvo`` (the default), ``flowvo-geometry`` and ``flowvo-pair``: geometry where geometry is strong,
the network where it is not.

Rotation and translation direction come from an essential matrix fitted to textured points tracked over
the whole frame (pyramidal Lucas-Kanade), a fast car's direction checked against the camera's forward axis
(:mod:`flowvo.travel_direction`; a refused step's rotation fitted again along the direction taken); the
metric step length from the road plane, triangulated from the dense DIS flow of the road ahead at the
working resolution and the camera height
(:mod:`flowvo.road_scale`), filtered by a smooth-speed prior (:mod:`flowvo.speed_prior`); standstill when
the road and the scene move less than half a pixel and braking at 1 g could have stopped the car. Where
no trustworthy road plane has been seen for a while, the packaged network's distance stands in
(``flowvo``; ``flowvo-geometry`` has no network). Lens distortion is removed from the tracked and road
points, not from whole frames. No ground truth enters it.

``flowvo`` and ``flowvo-geometry`` refine the step lengths in a window stage (:mod:`flowvo.scale_window`):
each step also measures the ratio of its length to the last one from points tracked over three frames
(:mod:`flowvo.scale_propagation`), and the window fuses road, ratios and network over about two seconds,
emitting each motion a fixed number of frames late. ``flowvo-pair`` is the per-pair estimate alone (the
speed prior's length, no latency), kept for comparison.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import cv2
import numpy as np

from flowvo.bundle_window import BundleSettings, BundleWindow
from flowvo.camera import Camera, distort_points, undistort_points
from flowvo.errors import FlowvoError
from flowvo.flow.registry import create_estimator
from flowvo.geometry import invert_se3, so3_exp, so3_log
from flowvo.landmark_tracks import AGREE_PX, RETURN_PX, SPACING_PX, Landmarks, LandmarkTracker
from flowvo.methods.base import MIN_FLOW_SIDE_PX, REFERENCE_WIDTH_PX, WorkingFrames
from flowvo.methods.cnn import CnnStep
from flowvo.road_scale import (
    NetworkFallbackPolicy,
    RoadNormal,
    RoadPlaneTally,
    onward_road_homography,
    road_crop,
    road_flow_within_reach,
    road_grid,
    road_homography,
    road_points_in_view,
    road_room,
    trusted_road_plane,
)
from flowvo.rotation_key import RotationKeyFrame
from flowvo.scale_propagation import MIN_PARALLAX_PX, LengthRatio, step_length_ratio
from flowvo.scale_window import ScaleWindow, StepRecord, StepScale
from flowvo.speed_prior import SpeedPrior
from flowvo.travel_direction import TravelDirection
from flowvo.two_view import (
    EssentialMotion,
    direction_given_rotation,
    essential_motion,
    follow_flow,
    lucas_kanade,
    motion_along,
    se3_next_prev,
    textured_points,
    track_points,
)
from flowvo.yaw_rate import YawRateCheck

DEFAULT_ROAD_FLOW_METHOD = "dis-road"  # DIS down to the working resolution (the presets' road flow, one pyramid
# level short, made every step 3-6 % short on real KITTI), lighter where that cost nothing (flow.classical)
DEFAULT_WORKING_WIDTH = 620  # KITTI at half width: the road's flow is fine enough, the step runs at 100 frames/s
STILL_FLOW_PX = 0.5  # at the reference width: below this median motion of road and scene, the car stands still
TRACK_WINDOW_PX = 11  # Lucas-Kanade window: half the cost of 15 px windows, rotations and directions alike on
# the real clips (t_err with the true step lengths over widths 600/620/640: 1.25 / 0.71 / 0.61 % against
# 1.21 / 0.69 / 0.59 %)
MIN_FRAME_WIDTH_PX = 128  # measured on 20 frames of clip 06 (23.6 m) resized: 128x90 px gave 24.0 m, 96x90
# 29.7 m, 64x90 a standstill (too few road and tracked points to fit anything)
DIS_REACH_PX = 12.0  # at the reference width: road motion DIS follows without a prediction; beyond, it
# under-estimates it (one step's near road decides, a key frame's span its median: road_scale.road_flow_within_reach)
KEY_ROAD_PX = DIS_REACH_PX / 2  # a step whose road moved less keeps its road key frame, so the road scale is
# measured over a longer baseline (two such steps stay within DIS's reach;
# synthetic 30 frames/s drive: 8.4 -> 3.0 %, the same drive at 10: 3.2 -> 3.0 %; real clip 01 1.30 -> 1.10 %)
ROAD_WARP_INTERPOLATION = cv2.INTER_CUBIC  # how the current frame is warped onto the predicted road: bilinear
# interpolation blurs it where the prediction falls between pixels, and DIS, matching it against the sharp previous
# frame, measured 1-2 px of road flow 3.5-4.5 % long (bicubic: 2-3 %); real clips over working widths 600-640 px,
# medians 1.15 / 0.95 / 1.32 -> 1.09 / 0.88 / 1.20 % (25 of the 33 widths better); Lanczos spread clip 06 1.54x
MAX_ROAD_KEY_S = 0.5  # a road key frame older than this is replaced even when the road moved little
MAX_KEY_PREDICTION_SPEED_MPS = 6.0  # below it a kept road key frame's flow is predicted too (as the previous
# frame's is): clip 07 over working widths 1.63 -> 1.47 % (median); at any speed as good, but earlier a wrong
# two-step plane at 12 m/s passed every gate on a generated drive
TIME_TOLERANCE_S = 1e-6  # timestamps from different containers differ in their last bits (0.3 against
# 0.30000000000000004): an age compared with MAX_ROAD_KEY_S must not depend on them
CONTINUE_EVERY = 6  # every sixth tracked point is followed into the next frame too (three-view ratios): all
# of them, every third and every sixth measured alike on the real clips; each hundred costs 0.75 ms of LK
MIN_ROAD_PARALLAX_PX = 1.0  # at the reference width: a road whose points moved less (after the rotation, nine in
# ten of them) since the road key frame has lost its flow (no texture; synthetic replay 10, 0.3-1.5 px at 0.5-0.9 m
# a step: flowvo-geometry 28.3 % without this gate, 6.9 % with it); the median instead of the 90th percentile
# also rejected real clip 07's start at walking pace, where the far rows barely move
MAX_KEY_ROTATION_OFF_DEG = 0.5  # a step rotation from the rotation key frame further off the pair's is a failed fit
# (the pair's rotations are 0.005-0.015 degrees off the truth, rms, on the synthetic drives)
ESSENTIAL_THRESHOLD_PX = 0.25  # at the reference width: USAC inlier threshold (LK tracks are sub-pixel)
ROBUST_SCALE_PX = 0.06  # at the reference width: Cauchy scale of the robust refit of each essential fit
# (two_view.refined_motion): synthetic replays 08-10 pooled 1.13 -> 0.99 %, 0.0039 -> 0.0033 deg/m; 0.03 px
# scored 0.95 % there but spread the real clips wider over the working widths (06: 1.51x)


@dataclass(frozen=True)
class GeometryFrame:
    """A working frame of the default method with its textured points, the tracks of the previous frame's
    textured points into it, and ``continued_next``: where the previous frame's tracks (its
    ``tracked_next``, rows ``continued_rows``) went on to in this frame (computed once per frame, in order,
    in the reader thread; empty for the first frame), and for ``flowvo-ba`` the ``landmarks`` tracked over many
    frames (:mod:`flowvo.landmark_tracks`); pixels of the (distorted) working frame."""

    image: np.ndarray
    textured_px: np.ndarray
    tracked_prev: np.ndarray
    tracked_next: np.ndarray
    continued_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    continued_next: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.float32))
    landmarks: Landmarks | None = None


@dataclass(frozen=True)
class GeometryFlow:
    """What the default method measures between two working frames, in undistorted pixels: ``motion_prev``
    -> ``motion_next`` (M, 2) tracked textured points for the rotation and translation direction, and
    ``road_prev`` -> ``road_next`` (R, 2) road-band points that stay in view, moved by the dense flow of the road crop
    from the road key frame (the previous frame, or an earlier one while the road moves little) to the
    current one, with ``key_prev`` -> ``key_next`` the key frame's textured points tracked into the current
    frame (None when the key frame is the previous frame), and ``rotation_key_prev`` -> ``rotation_key_next`` the
    rotation key frame's (:mod:`flowvo.rotation_key`; None when the step's rotation is measured from the
    previous frame)."""

    motion_prev: np.ndarray
    motion_next: np.ndarray
    road_prev: np.ndarray
    road_next: np.ndarray
    current: GeometryFrame
    key_prev: np.ndarray | None = None
    key_next: np.ndarray | None = None
    rotation_key_prev: np.ndarray | None = None
    rotation_key_next: np.ndarray | None = None


class FlowGeometryStep(WorkingFrames):
    """The default method (see the module docstring); with a ``fallback`` network it is ``flowvo``, without
    ``flowvo-geometry``."""

    motion_stage = "geometry"
    opencv_threads: int | None = 1  # its stages balance across the stream's two threads

    def __init__(self, camera: Camera, image_size_hw: tuple[int, int],
                 flow_method: str = DEFAULT_ROAD_FLOW_METHOD, working_width: int = DEFAULT_WORKING_WIDTH,
                 fallback: CnnStep | None = None, window: ScaleWindow | None = None,
                 bundle: BundleSettings | None = None) -> None:
        super().__init__(camera, image_size_hw, working_width)
        if bundle is not None and window is None:
            raise FlowvoError("the bundle stage takes its motions from the scale window: give both")
        name = ("flowvo-pair" if window is None else "flowvo-ba" if bundle else
                "flowvo" if fallback else "flowvo-geometry")
        self.window = window
        self.bundle = None if bundle is None else BundleWindow(self.K, bundle)  # behind the scale window (flowvo-ba)
        self.latency_frames = (window.latency_frames if window else 0) + \
            (self.bundle.latency_frames if self.bundle else 0)
        self.label = (f"{name} ({flow_method} road flow, geometry" + (", network fallback" if fallback else "")
                      + (f", {window.latency_frames}-frame scale window" if window else ", per pair")
                      + (f", {self.bundle.frames}-frame bundle adjustment)" if self.bundle else ")"))
        scale = self.working_hw[1] / REFERENCE_WIDTH_PX
        self.landmark_tracker = None if self.bundle is None else \
            LandmarkTracker(SPACING_PX * scale, RETURN_PX * scale, AGREE_PX * scale)
        self._landmark_views: dict[float, Landmarks] = {}  # undistorted, by frame time, until the bundle takes them
        if fallback is not None and (fallback.network.stack != 1 or fallback.working_hw != self.working_hw):
            raise FlowvoError("the fallback network must take one flow field at the default method's frame size")
        self.fallback = fallback
        self.fallback_policy = NetworkFallbackPolicy()
        self.road_tally = RoadPlaneTally()
        self.estimator = create_estimator(flow_method)
        self.camera_height_m = self.camera.camera_height_m
        self.levelling = self.camera.road_levelling if self.camera.pitch_deg else None  # road planes about the road's
        # normal (a camera mounted level needs no rotation)
        if image_size_hw[1] < MIN_FRAME_WIDTH_PX:
            raise FlowvoError(f"frames of {image_size_hw[1]}x{image_size_hw[0]} px are too narrow for the default "
                              f"method: it needs at least {MIN_FRAME_WIDTH_PX} px (narrower ones give a wrong or "
                              "no trajectory); use larger frames or --method classical")
        no_room = road_room(image_size_hw, camera.intrinsics.K)
        if no_room:
            raise FlowvoError(f"{no_room} (check the intrinsics; --method classical needs no road)")
        self.crop = road_crop(self.working_hw, self.K)
        crop_hw = (self.crop[0].stop - self.crop[0].start, self.crop[1].stop - self.crop[1].start)
        if min(crop_hw) < MIN_FLOW_SIDE_PX:  # OpenCV's DIS crashes the process on smaller fields
            raise FlowvoError(f"frames of {image_size_hw[1]}x{image_size_hw[0]} px are too small for the default "
                              f"method: its road crop is {crop_hw[1]}x{crop_hw[0]} px, the flow needs at least "
                              f"{MIN_FLOW_SIDE_PX} px a side (frames at least 90 px high and "
                              f"{MIN_FRAME_WIDTH_PX} px wide work)")
        self.road_px = road_grid(self.working_hw, self.K)
        self.road_px_undistorted = self._undistort(self.road_px)
        self.crop_origin = np.array([self.crop[1].start, self.crop[0].start], dtype=np.float32)
        self.still_flow_px = STILL_FLOW_PX * self.working_hw[1] / REFERENCE_WIDTH_PX
        self.threshold_px = ESSENTIAL_THRESHOLD_PX * self.working_hw[1] / REFERENCE_WIDTH_PX
        self.robust_scale_px = ROBUST_SCALE_PX * self.working_hw[1] / REFERENCE_WIDTH_PX
        self.speed = SpeedPrior()
        car_axes = np.eye(3) if self.levelling is None else self.levelling.T  # columns: the car's right, down
        # and forward axes in the camera frame (a pitched camera's are turned by its pitch)
        self.travel = TravelDirection(car_axes[:, 2])  # along the road
        self.yaw_rate = YawRateCheck(car_axes[:, 1])  # yaw turns about the car's vertical axis
        self.road_normal = RoadNormal()
        self.last_motion = np.eye(4)
        # the last moving step's motion and its undistorted tracks (motion_prev, motion_next): three-view ratios
        self._last_step: tuple[EssentialMotion, np.ndarray, np.ndarray] | None = None
        self._step_scale: StepScale | None = None  # the last step, for the window stage
        self.min_parallax_px = MIN_PARALLAX_PX * self.working_hw[1] / REFERENCE_WIDTH_PX
        self.min_road_parallax_px = MIN_ROAD_PARALLAX_PX * self.working_hw[1] / REFERENCE_WIDTH_PX
        self._previous: GeometryFrame | None = None
        self._road_prediction: np.ndarray | None = None  # road homography previous -> current, predicted
        self.key_road_px = KEY_ROAD_PX * self.working_hw[1] / REFERENCE_WIDTH_PX
        self.dis_reach_px = DIS_REACH_PX * self.working_hw[1] / REFERENCE_WIDTH_PX
        self._road_key: GeometryFrame | None = None  # where the next step's road flow starts (None: previous)
        self._key_time_s, self._key_steps = 0.0, 0
        self.rotation_key: RotationKeyFrame[GeometryFrame] = RotationKeyFrame()
        self.rotation_key_steps = 0  # steps whose rotation was measured from an earlier key frame
        self._crop_to_frame = np.array([[1.0, 0.0, self.crop_origin[0]], [0.0, 1.0, self.crop_origin[1]],
                                        [0.0, 0.0, 1.0]])
        rows, columns = np.mgrid[self.crop[0], self.crop[1]]
        self._crop_ideal_px = self._undistort(np.stack([columns.ravel(), rows.ravel()], axis=1).astype(np.float32))

    def _undistort(self, points_px: np.ndarray) -> np.ndarray:
        return undistort_points(points_px, self.K, self.camera.distortion)

    def prepare(self, image: np.ndarray) -> GeometryFrame:
        """The working frame, its textured points and the tracks from the previous frame (tracking here
        balances the reader and flow threads: measured 85 -> 98 frames/s on two cores, clip 07)."""
        working = super().prepare(image)
        previous = self._previous
        textured = textured_points(working)
        landmarks = None if self.landmark_tracker is None else self.landmark_tracker.advance(working, textured)
        if previous is None:
            self._previous = GeometryFrame(working, textured, *(np.zeros((0, 2), np.float32),) * 2,
                                           landmarks=landmarks)
            return self._previous
        continued_rows = np.arange(0, len(previous.tracked_next), CONTINUE_EVERY) if self.window else \
            np.zeros(0, np.int64)
        count = len(previous.textured_px)
        start = np.concatenate([previous.textured_px, previous.tracked_next[continued_rows]])
        moved, found = lucas_kanade(previous.image, working, start, TRACK_WINDOW_PX)  # one call: each point is
        # tracked alone
        self._previous = GeometryFrame(working, textured, start[:count][found[:count]],
                                       moved[:count][found[:count]], continued_rows[found[count:]],
                                       moved[count:][found[count:]], landmarks)
        return self._previous

    def flow(self, previous: GeometryFrame, current: GeometryFrame) -> GeometryFlow:
        """Point tracks over the whole frame (from ``prepare``), the dense flow of the road crop from the
        road key frame and the key frames' tracks (see :class:`GeometryFlow`)."""
        motion = self._undistort(current.tracked_prev), self._undistort(current.tracked_next)
        key = previous if self._road_key is None else self._road_key
        road = self.road_flow(key.image, current.image, self._road_prediction)
        key_tracks = (None, None) if key is previous else self._tracks_from(key, current)
        rotation_key = self.rotation_key.frame
        rotation_tracks = (None, None) if rotation_key is None else \
            key_tracks if rotation_key is key else self._tracks_from(rotation_key, current)
        return GeometryFlow(*motion, *road, current, *key_tracks, *rotation_tracks)

    def _tracks_from(self, key: GeometryFrame, current: GeometryFrame) -> tuple[np.ndarray, np.ndarray]:
        """The key frame's textured points tracked into ``current``: where they were and went, undistorted."""
        key_prev, key_next = track_points(key.image, current.image, key.textured_px, TRACK_WINDOW_PX)
        return self._undistort(key_prev), self._undistort(key_next)

    def road_flow(self, previous: np.ndarray, current: np.ndarray, prediction: np.ndarray | None
                  ) -> tuple[np.ndarray, np.ndarray]:
        """The road grid points of working frame ``previous`` that stay in view, and where they are in
        ``current``, each (R, 2), undistorted working pixels (:func:`road_points_in_view`: the nearest road
        leaves the frame on a long step).

        With a ``prediction`` (a road homography ``previous -> current`` on undistorted working pixels: the
        default method passes the last step's plane and motion, constant velocity, where that step found the
        road plane), the current frame is first warped onto the previous frame's road by it, and DIS
        measures only what the prediction missed: large road motion (fast driving, low frame rates) stays
        within reach of the flow, points that leave the crop are still seen, and the residual is small and
        nearly uniform, which DIS measures best. On the real clips the road step lengths against the truth
        scattered less (inter-quartile range 4.7 against 7.1 %, with dis-medium-fine) than when only road
        motion over 12 px was predicted. The homography acts on undistorted pixels; with lens
        distortion the warp goes through the lens."""
        return road_points_in_view(self.road_px_undistorted, self._road_moved(previous, current, prediction),
                                   self.working_hw)

    def _road_moved(self, previous: np.ndarray, current: np.ndarray, prediction: np.ndarray | None) -> np.ndarray:
        """Where every road grid point of ``previous`` is in ``current`` (R, 2), undistorted working pixels
        (see :meth:`road_flow`)."""
        grid = self.road_px - self.crop_origin
        previous_crop = np.ascontiguousarray(previous[self.crop])
        if prediction is None:
            flow = self.estimator.estimate(previous_crop, np.ascontiguousarray(current[self.crop]))
            return self._undistort(follow_flow(grid, flow) + self.crop_origin)
        height, width = previous_crop.shape
        if self.camera.distortion.is_none:
            crop_to_current = prediction @ self._crop_to_frame
            warped = cv2.warpPerspective(current, crop_to_current, (width, height),
                                         flags=ROAD_WARP_INTERPOLATION | cv2.WARP_INVERSE_MAP,
                                         borderMode=cv2.BORDER_REPLICATE)
            moved = follow_flow(grid, self.estimator.estimate(previous_crop, warped))
            return _transform(moved, crop_to_current)
        ideal_in_current = _transform(self._crop_ideal_px, prediction)
        source = distort_points(ideal_in_current, self.K, self.camera.distortion).astype(np.float32)
        source = source.reshape(height, width, 2)
        warped = cv2.remap(current, source[..., 0], source[..., 1], ROAD_WARP_INTERPOLATION,
                           borderMode=cv2.BORDER_REPLICATE)
        moved = follow_flow(grid, self.estimator.estimate(previous_crop, warped)) + self.crop_origin
        return _transform(self._undistort(moved), prediction)

    def motion(self, times_s: tuple[float, float], previous: GeometryFrame, flow: GeometryFlow) -> np.ndarray:
        """``T_prev_cur`` of the step between ``times_s`` (previous, current), seconds: the per-pair estimate
        (the window stage, :meth:`refine`, may change its length)."""
        time_s, dt_s = times_s[1], times_s[1] - times_s[0]
        if self.bundle is not None:
            if not self.bundle.started and not self._landmark_views:  # the drive's first frame
                self._landmark_views[times_s[0]] = self._undistorted_landmarks(previous)
            self._landmark_views[time_s] = self._undistorted_landmarks(flow.current)
        last_step, self._last_step, self._step_scale = self._last_step, None, None
        moved_px = np.linalg.norm(flow.motion_next - flow.motion_prev, axis=1)
        road_motion_px = np.linalg.norm(flow.road_next - flow.road_prev, axis=1)
        road_moved_px = float(np.median(road_motion_px)) if len(road_motion_px) else 0.0
        key_is_previous = flow.key_prev is None
        key_frame = previous if key_is_previous else self._road_key
        key_time_s = times_s[0] if key_is_previous else self._key_time_s
        key_steps = 1 if key_is_previous else self._key_steps + 1
        road_measured = road_flow_within_reach(road_motion_px, self.dis_reach_px, self._road_prediction is not None,
                                               key_steps)
        self._road_key, self._road_prediction = None, None  # by default the next step starts from this frame
        still = road_moved_px / key_steps < self.still_flow_px and (not len(moved_px) or
                                                                  np.median(moved_px) < self.still_flow_px)
        if still and self.speed.could_stand_at(time_s):
            self.rotation_key.forget()
            self.yaw_rate.forget()
            self.speed.stop(time_s)  # the road and the scene stand still (distant points alone can mislead)
            self.last_motion = np.eye(4)
            return self.last_motion
        # a car too fast to have stopped, with only distant scenery in view, is degenerate too
        fit = None if still else self._essential(flow.motion_prev, flow.motion_next)
        if fit is None:  # degenerate: keep the last motion (constant velocity)
            self.road_normal.forget()
            self.rotation_key.forget()
            self.yaw_rate.forget()
            T_next_prev = invert_se3(self.last_motion)
            length_m = float(np.linalg.norm(T_next_prev[:3, 3]))
            self._step_scale = StepScale(T_next_prev[:3, :3], T_next_prev[:3, 3] / max(length_m, 1e-12), length_m,
                                         dt_s)
            return self.last_motion
        road_key_fit = None if key_is_previous else self._essential(flow.key_prev, flow.key_next)
        if flow.rotation_key_prev is not None:  # the same key frame's tracks share the road key's fit
            fit = self._over_rotation_key(fit, road_key_fit if flow.rotation_key_prev is flow.key_prev else
                                          self._essential(flow.rotation_key_prev, flow.rotation_key_next), flow)
        yaw_checked = self._yaw_checked(fit, flow, dt_s)
        fit = self._travel_checked(yaw_checked, flow)
        if fit is not yaw_checked:
            self.yaw_rate.took(so3_log(fit.R), dt_s)
        self.rotation_key.advance((times_s[0], previous), time_s, fit.R)
        key_fit = fit if key_is_previous else road_key_fit
        self.road_normal.advance(fit.R, dt_s)
        plane = None if key_fit is None else trusted_road_plane(
            flow.road_prev, flow.road_next, self.K, key_fit, min_parallax_px=self.min_road_parallax_px,
            levelling=self.levelling, tally=self.road_tally)
        if plane is not None:
            plane = self.road_normal.smoothed(plane, key_fit.R, keep=road_measured)
        road_m = None if plane is None else self.camera_height_m / plane.distance  # since the key frame
        # per pair: this step's share of it, at the speed it gives
        step_m = None if road_m is None else road_m * dt_s / (time_s - key_time_s)
        key_young = time_s - key_time_s < MAX_ROAD_KEY_S - TIME_TOLERANCE_S
        if plane is not None and road_moved_px < self.key_road_px and key_young:
            # the road moved too little for a precise scale: the next step measures from the same key frame
            self._road_key, self._key_time_s, self._key_steps = key_frame, key_time_s, key_steps
            last_speed_mps = self.speed.last_speed_mps
            if last_speed_mps is not None and last_speed_mps < MAX_KEY_PREDICTION_SPEED_MPS:
                # this step's share of the road by the count of steps, not by time: the warp DIS sees must not
                # depend on the timestamps' last bits (a bag's stamps against times.txt: 2 % apart otherwise)
                self._road_prediction = onward_road_homography(self.K, plane, key_fit, road_m, fit,
                                                               road_m / key_steps, self.camera_height_m)
        elif plane is not None and key_is_previous:
            self._road_prediction = road_homography(self.K, fit, plane)
        network_m = None
        if step_m is not None:
            self.fallback_policy.road_seen(time_s)
        elif self.fallback is not None and self.fallback_policy.network_needed(time_s):
            step_m = network_m = self.fallback.distance_m(previous.image, flow.current.image)  # the speed prior
            # alone would drift
        speed_mps = self.speed.update(time_s, None if step_m is None else step_m / dt_s)
        step_m = 0.0 if speed_mps is None else speed_mps * dt_s
        self.last_motion = invert_se3(se3_next_prev(fit.R, fit.t_dir * step_m))
        if self.window is not None:
            plausible = road_m is not None and road_m <= self.speed.max_speed_at(time_s) * (time_s - key_time_s)
            ratio = None if last_step is None else self._length_ratio(last_step, flow.current, fit)
            self._step_scale = StepScale(fit.R, fit.t_dir, step_m, dt_s, road_m if plausible else None, network_m,
                                         *((None, 0.0) if ratio is None else ratio), road_steps=key_steps)
            self._last_step = fit, flow.motion_prev, flow.motion_next
        return self.last_motion

    def _essential(self, points_prev: np.ndarray, points_next: np.ndarray) -> EssentialMotion | None:
        """The motion up to scale from undistorted tracks (N, 2): USAC's essential fit, refitted robustly over its
        inliers (:func:`flowvo.two_view.refined_motion`); None where USAC finds none."""
        return essential_motion(points_prev, points_next, self.K, threshold_px=self.threshold_px,
                                robust_scale_px=self.robust_scale_px)

    def _over_rotation_key(self, fit: EssentialMotion, key_fit: EssentialMotion | None, flow: GeometryFlow
                           ) -> EssentialMotion:
        """The step's motion with its rotation measured from the rotation key frame (:mod:`flowvo.rotation_key`;
        ``key_fit``: the fit of the key frame's tracks into the current frame) and its direction fitted again
        under that rotation to the pair's inlier tracks; the pair's ``fit`` where the key frame's tracks give no
        fit or one whose step rotation lies over ``MAX_KEY_ROTATION_OFF_DEG`` off the pair's."""
        if key_fit is None:
            return fit
        R = self.rotation_key.step_rotation(key_fit.R)
        if np.degrees(np.linalg.norm(so3_log(R @ fit.R.T))) > MAX_KEY_ROTATION_OFF_DEG:
            return fit
        self.rotation_key_steps += 1
        return self._under_rotation(fit, R, flow)

    def _under_rotation(self, fit: EssentialMotion, R: np.ndarray, flow: GeometryFlow) -> EssentialMotion:
        """The step's motion with rotation ``R`` (``R_next_prev``) and the direction fitted again under it to the
        pair's inlier tracks of ``fit`` (:func:`direction_given_rotation`)."""
        inliers = fit.inliers
        return EssentialMotion(R, direction_given_rotation(flow.motion_prev[inliers], flow.motion_next[inliers], self.K,
                                                           R, fit.t_dir), inliers)

    def _travel_checked(self, fit: EssentialMotion, flow: GeometryFlow) -> EssentialMotion:
        """The step's motion up to scale: the fit, or, where its direction of travel lies further off the forward
        axis than a fast car's can (:mod:`flowvo.travel_direction`), the motion along the last direction taken
        at speed with its rotation fitted again to the tracks (:func:`motion_along`: the fit's rotation came
        with its wrong direction; kept where no rotation along that direction explains 30 tracks)."""
        direction = -fit.R.T @ fit.t_dir  # of travel, in the first frame of the step
        taken = self.travel.checked(direction, self.speed.last_speed_mps)
        if taken is direction:
            return fit
        along = motion_along(flow.motion_prev, flow.motion_next, self.K, taken, fit.R, self.threshold_px)
        return along if along is not None else EssentialMotion(fit.R, -fit.R @ taken, fit.inliers)

    def _yaw_checked(self, fit: EssentialMotion, flow: GeometryFlow, dt_s: float) -> EssentialMotion:
        """The step's motion up to scale: the fit, or, where its yaw rate jumped further from the last one taken
        than a car's can below 6 m/s (:mod:`flowvo.yaw_rate`: a failed fit), the last yaw rate's rotation with the
        direction fitted again under it to the pair's inlier tracks."""
        rotation = so3_log(fit.R)
        taken = self.yaw_rate.checked(rotation, dt_s, self.speed.last_speed_mps)
        return fit if taken is rotation else self._under_rotation(fit, so3_exp(taken), flow)

    def _length_ratio(self, last_step: tuple[EssentialMotion, np.ndarray, np.ndarray], current: GeometryFrame,
                      fit: EssentialMotion) -> LengthRatio | None:
        """This step's length over the last one's (:mod:`flowvo.scale_propagation`), from the last step's
        inlier tracks (its fit and undistorted tracks) that went on into ``current``."""
        last_fit, before, at = last_step
        inlier = last_fit.inliers[current.continued_rows]  # rows of the last step's tracks
        rows = current.continued_rows[inlier]
        return step_length_ratio((before[rows], at[rows]), last_fit, (at[rows], self._undistort(
            current.continued_next[inlier])), fit, self.K, self.min_parallax_px)

    def _undistorted_landmarks(self, frame: GeometryFrame) -> Landmarks:
        """The frame's landmark tracks in undistorted working pixels."""
        return Landmarks(frame.landmarks.ids, self._undistort(frame.landmarks.px))

    def measured(self) -> StepScale | None:
        """What the last :meth:`motion` measured of its step's length, for the window (None: a standstill)."""
        return self._step_scale

    def refine(self, time_s: float, motion: np.ndarray, measured: StepScale | None
               ) -> list[tuple[float, np.ndarray]]:
        """The window stage: the step ending at ``time_s`` (``motion`` and what :meth:`measured` gave for it)
        goes into the scale window; the motions now final come back, ``latency_frames`` late (per pair: at
        once; ``flowvo-ba``: then through the bundle stage, ``bundle.latency_frames`` later)."""
        if self.window is None:
            return [(time_s, motion)]
        return self._bundled(self.window.push(time_s, measured))

    def flush(self) -> list[tuple[float, np.ndarray]]:
        """The motions still in the window (and the bundle stage) at the end of the drive."""
        if self.window is None:
            return []
        final = self._bundled(self.window.flush())
        return final if self.bundle is None else final + self.bundle.flush()

    def _bundled(self, final: list[tuple[float, np.ndarray]]) -> list[tuple[float, np.ndarray]]:
        """The scale window's ``final`` motions through the bundle stage, each step's length sigma from the
        window's records."""
        if self.bundle is None or not final:
            return final
        records = self.window.records[len(self.window.records) - len(final):]
        bundled = []
        for (time_s, motion), record in zip(final, records, strict=True):
            if not self.bundle.started:
                first_time_s = min(self._landmark_views)
                bundled += self.bundle.push(first_time_s, None, *self._landmark_views.pop(first_time_s))
            bundled += self.bundle.push(time_s, motion, *self._landmark_views.pop(time_s), record.log_sigma)
        return bundled

    def step_records(self) -> list[StepRecord] | None:
        """What became of each final step so far (the window's records; None per pair)."""
        return None if self.window is None else self.window.records

    def summary(self) -> dict:
        """How many steps took the network's distance (no trustworthy road plane for a while), how the road
        planes fared (:class:`RoadPlaneTally`), how many steps at speed took the last direction of travel
        instead of the fit's (:mod:`flowvo.travel_direction`), how many took the last yaw rate instead of the
        fit's (:mod:`flowvo.yaw_rate`), how many steps' rotations were measured from an earlier key frame
        (:mod:`flowvo.rotation_key`), the window's latency (frames: how late each motion is final), how many
        steps each kind of measurement reached, the median standard deviation of a step's log length and how
        many moving steps no measurement of the scale reached (:class:`StepRecord`)."""
        kept = {"network_distance_steps": self.fallback_policy.network_steps} if self.fallback else {}
        kept["road_planes"] = self.road_tally.record()
        kept["direction_kept_steps"] = self.travel.kept_steps
        kept["yaw_refused_steps"] = self.yaw_rate.refused_steps
        kept["rotation_key_steps"] = self.rotation_key_steps
        if self.window is not None:
            records = self.window.records
            sigmas = [record.log_sigma for record in records if record.log_sigma is not None]
            kept["scale_window"] = {"latency_frames": self.window.latency_frames, "window_s": self.window.window_s,
                                    "steps_measured_by": dict(Counter(record.measured_by for record in records)),
                                    "median_length_log_sigma": float(np.median(sigmas)) if sigmas else None,
                                    "unscaled_steps": sum(record.unscaled for record in records)}
        if self.bundle is not None:
            kept["bundle"] = {"latency_frames": self.bundle.latency_frames, "frames": self.bundle.frames,
                              "every": self.bundle.every, "solves": self.bundle.solves,
                              "dropped_observations": self.bundle.dropped_observations}
        return kept


def _transform(points_px: np.ndarray, homography: np.ndarray) -> np.ndarray:
    """Points (N, 2) mapped by a 3x3 homography, float32."""
    mapped = cv2.perspectiveTransform(np.asarray(points_px, np.float64).reshape(-1, 1, 2), homography)
    return mapped.reshape(-1, 2).astype(np.float32)
