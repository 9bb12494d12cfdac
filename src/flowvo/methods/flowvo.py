"""``flowvo`` (the default), ``flowvo-geometry``, ``flowvo-pair`` and ``flowvo-ba``: the assembly of the engine's
stages (:mod:`flowvo.odometry`) into the per-frame step. Geometry where geometry is strong, the network where it
is not; no ground truth enters it.

Per frame: textured points tracked over the whole frame (pyramidal Lucas-Kanade) and the dense DIS flow of the
road ahead (:mod:`~flowvo.odometry.road_flow`, from the road key frame: :mod:`~flowvo.odometry.road_key`). Per
step: the standstill test (road and scene under half a pixel in 0.1 s, and braking at 1 g could have stopped the
car; a faster frame's step under half a pixel is a creeping car, taken straight ahead); the essential fit and
its checks (:mod:`~flowvo.odometry.motion_checks`); the road plane and the metres it gives from the camera
height (:mod:`~flowvo.odometry.road_length`); the packaged network's distance where no trusted road was seen
for a while (``flowvo``; ``flowvo-geometry`` has none); the smooth-speed prior
(:mod:`~flowvo.odometry.speed_prior`). Lens distortion is removed from the tracked and road points, not from whole
frames.

``flowvo``, ``flowvo-geometry`` and ``flowvo-ba`` refine the step lengths in a window stage
(:mod:`~flowvo.odometry.scale_window`): each step also measures the ratio of its length to the last one from points
tracked over three frames (:mod:`~flowvo.odometry.scale_propagation`), and the window fuses road, ratios and
network over about two seconds, emitting each motion a fixed number of frames late (``flowvo-ba``: then through
the bundle stage, :mod:`~flowvo.odometry.bundle_window`). ``flowvo-pair`` is the per-pair estimate alone.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from flowvo.camera import KITTI_CAMERA_HEIGHT_M, Camera
from flowvo.errors import FlowvoError
from flowvo.geometry import invert_se3
from flowvo.methods.base import MIN_FLOW_SIDE_PX, REFERENCE_WIDTH_PX, WorkingFrames
from flowvo.methods.cnn import CnnStep
from flowvo.methods.geometry_frames import GeometryFlow, GeometryFrame
from flowvo.odometry.bundle_window import BundleSettings, BundleWindow
from flowvo.odometry.landmark_tracks import AGREE_PX, RETURN_PX, SPACING_PX, Landmarks, LandmarkTracker
from flowvo.odometry.motion_checks import MotionChecks
from flowvo.odometry.numeric import median, row_norms
from flowvo.odometry.road_flow import RoadFlow
from flowvo.odometry.road_key import BASELINE_PX, DIS_REACH_PX, KEY_ROAD_PX, RoadKeyFrame, RoadSpan
from flowvo.odometry.road_length import RoadLength
from flowvo.odometry.road_plane import RoadPlane, in_camera_frame
from flowvo.odometry.road_scale import (
    NetworkFallbackPolicy,
    metric_road_homography,
    road_flow_within_reach,
    road_room,
)
from flowvo.odometry.rolling_shutter import baseline_shares, check_readout_within
from flowvo.odometry.scale_propagation import MIN_PARALLAX_PX, LengthRatio, step_length_ratio
from flowvo.odometry.scale_window import ScaleWindow, StepRecord, StepScale
from flowvo.odometry.speed_prior import SpeedPrior
from flowvo.odometry.static_layer import StaticLayer
from flowvo.odometry.still_regions import STILL_SHARE, StillRegions
from flowvo.odometry.two_view import (
    EssentialMotion,
    essential_motion,
    lucas_kanade,
    se3_next_prev,
    textured_points,
    track_points,
)
from flowvo.odometry.view_bottom import ViewBottom
from flowvo.odometry.window_stage import WindowStage, motion_in_metres

DEFAULT_ROAD_FLOW_METHOD = "dis-road"  # DIS down to the working resolution (the presets' road flow, one pyramid
# level short, made every step 3-6 % short on real KITTI), lighter where that cost nothing (flow.classical)
DEFAULT_WORKING_WIDTH = 620  # KITTI at half width: the road's flow is fine enough, the step runs at 100 frames/s
STILL_FLOW_PX = 0.5  # at the reference width: below this median motion of road and scene over STILL_SPAN_S (or
# a longer step), the car stands still
STILL_SPAN_S = 0.1  # KITTI's frame interval, at which STILL_FLOW_PX was set: at 30 frames/s a step of 0.5 px is
# 1.8 m/s, and a drive's stops and starts were cut as standstills (generated drive, seed 4: 1.9 m of 189 m lost,
# t_err 1.25 %)
TRACK_WINDOW_PX = 11  # Lucas-Kanade window: half the cost of 15 px windows, rotations and directions alike on
# the real clips (t_err with the true step lengths over widths 600/620/640: 1.25 / 0.71 / 0.61 % against
# 1.21 / 0.69 / 0.59 %)
MIN_FRAME_WIDTH_PX = 128  # measured on 20 frames of clip 06 (23.6 m) resized: 128x90 px gave 24.0 m, 96x90
# 29.7 m, 64x90 a standstill (too few road and tracked points to fit anything)
CONTINUE_EVERY = 6  # every sixth tracked point is followed into the next frame too (three-view ratios): all
# of them, every third and every sixth measured alike on the real clips; each hundred costs 0.75 ms of LK
MIN_ROAD_PARALLAX_PX = 1.0  # at the reference width: a road whose points moved less (after the rotation, nine in
# ten of them) since the road key frame has lost its flow (no texture; synthetic replay 10, 0.3-1.5 px at 0.5-0.9 m
# a step: flowvo-geometry 28.3 % without this gate, 6.9 % with it); the median instead of the 90th percentile
# also rejected real clip 07's start at walking pace, where the far rows barely move
LAYER_MOVING_PX = 3.0  # at the reference width: the tracks below the road's horizon moved this much in the median, or
# their frame stays out of the still layer's long exposure (:mod:`flowvo.odometry.static_layer`): the road of a slow
# start moves less than its texture's grain, and the two halves' exposures then share it (at 1 px, a synthetic
# dash-cam's first 40 frames read a layer of 0.10 that is not there)
STILL_TRACKS_FROM = 0.25  # frame heights below the principal point: tracks from there down are judged for still
# regions (odometry.still_regions; KITTI: the road 10 m ahead and nearer; nearer the horizon distant points ahead
# barely move, and on real clip 06 cells at 0.1-0.2 were taken for still)
ESSENTIAL_THRESHOLD_PX = 0.25  # at the reference width: USAC inlier threshold (LK tracks are sub-pixel)
ROBUST_SCALE_PX = 0.06  # at the reference width: Cauchy scale of the robust refit of each essential fit
# (two_view.refined_motion): synthetic replays 08-10 pooled 1.13 -> 0.99 %, 0.0039 -> 0.0033 deg/m; 0.03 px
# scored 0.95 % there but spread the real clips wider over the working widths (06: 1.51x)
ACQUISITION_STEPS = np.geomspace(0.05, 10.0, 48)  # step lengths (KITTI camera heights) a drive's first road
# prediction is chosen from where its road moved beyond DIS's reach, 12 % apart: DIS measures what is left. Without it
# a camera 1.2 m high starting at 36 m/s (49.5 KITTI camera heights a second) measured no road for 2 s
MAX_SPEED_MPS = 45.0  # a speed measured faster than this (162 km/h) for a camera LOW_CAMERA_HEIGHT_M high is a wrong
# road plane, refused; in proportion to the camera height, as every limit of the method (it works in camera heights)
LOW_CAMERA_HEIGHT_M = 1.0  # the lowest camera the limit holds for: a dash-cam 1.2 m high may read up to 54 m/s. With
# it at KITTI's 1.65 m a dash-cam 1.2 m high refused every road above 32.7 m/s: a synthetic motorway drive at 37 m/s
# (KITTI 01's path 1.4 times as fast) read 940 m of 1698, t_err 46.6 % (1.07 % for the camera at 1.65 m)


class FlowGeometryStep(WorkingFrames):
    """The default method (see the module docstring); with a ``fallback`` network it is ``flowvo``, without
    ``flowvo-geometry``. Its stages: :class:`RoadFlow` (the road's dense flow), :class:`RoadKeyFrame` (where that
    flow starts, and its prediction), :class:`MotionChecks` (the step's motion up to scale), :class:`RoadLength`
    (the road plane and the metres it gives), :class:`SpeedPrior`, the network fallback and the scale window."""

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
        self.stage: WindowStage | None = None  # the window stage (set below, once the unit is known; None per pair)
        self.latency_frames = (window.latency_frames if window else 0) + \
            (self.bundle.latency_frames if self.bundle else 0)
        self.label = (f"{name} ({flow_method} road flow, geometry" + (", network fallback" if fallback else "")
                      + (f", {window.latency_frames}-frame scale window" if window else ", per pair")
                      + (f", {self.bundle.frames}-frame bundle adjustment)" if self.bundle else ")"))
        scale = self.working_hw[1] / REFERENCE_WIDTH_PX
        self.landmark_tracker = None if self.bundle is None else \
            LandmarkTracker(SPACING_PX * scale, RETURN_PX * scale, AGREE_PX * scale)
        if fallback is not None and (fallback.network.stack != 1 or fallback.working_hw != self.working_hw):
            raise FlowvoError("the fallback network must take one flow field at the default method's frame size")
        self.fallback = fallback
        self.fallback_policy = NetworkFallbackPolicy()
        if image_size_hw[1] < MIN_FRAME_WIDTH_PX:
            raise FlowvoError(f"frames of {image_size_hw[1]}x{image_size_hw[0]} px are too narrow for the default "
                              f"method: it needs at least {MIN_FRAME_WIDTH_PX} px (narrower ones give a wrong or "
                              "no trajectory); use larger frames or --method classical")
        no_room = road_room(image_size_hw, camera.intrinsics.K)
        if no_room:
            raise FlowvoError(f"{no_room} (check the intrinsics; --method classical needs no road)")
        self.road = RoadFlow(self.camera, self.working_hw, flow_method, scale, MIN_FLOW_SIDE_PX)
        self.still_tracks = StillRegions(self.working_hw, self.K[1, 2] + STILL_TRACKS_FROM * self.working_hw[0], scale,
                                         STILL_SHARE / 2, band=True)
        self.view_bottom = ViewBottom(self.working_hw, self.still_tracks.first_row, self.still_tracks.cell_px)
        self.static_layer = StaticLayer(self.working_hw, self.road.from_level_top(), (self.K[0, 2], self.K[1, 2]),
                                        self.still_tracks.cell_px, self.still_tracks.first_row)
        self.frame_rows = image_size_hw[0]  # the frames' own height, for run.json's rows
        if min(self.road.crop_hw) < MIN_FLOW_SIDE_PX:  # OpenCV's DIS crashes the process on smaller fields
            raise FlowvoError(f"frames of {image_size_hw[1]}x{image_size_hw[0]} px are too small for the default "
                              f"method: its road crop is {self.road.crop_hw[1]}x{self.road.crop_hw[0]} px, the flow "
                              f"needs at least {MIN_FLOW_SIDE_PX} px a side (frames at least 90 px high and "
                              f"{MIN_FRAME_WIDTH_PX} px wide work)")
        self.still_flow_px = STILL_FLOW_PX * scale
        self.layer_moving_px = LAYER_MOVING_PX * scale
        self.threshold_px = ESSENTIAL_THRESHOLD_PX * scale
        self.robust_scale_px = ROBUST_SCALE_PX * scale
        self.speed = SpeedPrior(max_speed_mps=MAX_SPEED_MPS * KITTI_CAMERA_HEIGHT_M / LOW_CAMERA_HEIGHT_M)  # in the
        # method's units, KITTI camera heights (below)
        levelling = None if self.camera.is_level else self.camera.road_levelling  # road planes about the road's
        # normal (a camera mounted level needs no rotation)
        car_axes = np.eye(3) if levelling is None else levelling.T  # columns: the car's right, down and forward
        # axes in the camera frame (a pitched camera's are turned by its pitch)
        self.checks: MotionChecks[GeometryFrame] = MotionChecks(self.K, car_axes, self.threshold_px)
        # Lengths inside the method are in units of KITTI's camera height (metres for a camera 1.65 m high): every
        # threshold in metres or m/s (the speed prior's limits, the gates by speed, the network's distance) then
        # acts alike at any height, and each length given out is exactly proportional to the height
        self.metres_per_unit = self.camera.camera_height_m / KITTI_CAMERA_HEIGHT_M
        self.road_length = RoadLength(self.K, KITTI_CAMERA_HEIGHT_M, self.camera.pitch_deg, self.camera.roll_deg,
                                      MIN_ROAD_PARALLAX_PX * scale)
        self.road_key: RoadKeyFrame[GeometryFrame] = RoadKeyFrame(self.K, KEY_ROAD_PX * scale, KITTI_CAMERA_HEIGHT_M,
                                                                  BASELINE_PX * scale)
        self.road_too_fast_steps = 0  # road lengths the window was not given: faster than a car could have driven
        if window is not None:
            self.stage = WindowStage(window, self.bundle, self.metres_per_unit)
        self.dis_reach_px = DIS_REACH_PX * scale
        self.min_parallax_px = MIN_PARALLAX_PX * scale
        self.last_motion = np.eye(4)
        # the last moving step's motion and its undistorted tracks (motion_prev, motion_next): three-view ratios; all
        # in the method's units
        self._last_step: tuple[EssentialMotion, np.ndarray, np.ndarray] | None = None
        self._step_scale: StepScale | None = None  # the last step, for the window stage
        self._previous: GeometryFrame | None = None
        self._readout_checked = False  # against the first two frames' interval
        # read only, for live views (flowvo.api.rerun): (time_s, flow, fit, trusted road plane) of the last step
        self.last_view: tuple[float, GeometryFlow, EssentialMotion | None, RoadPlane | None] | None = None

    def prepare(self, image: np.ndarray) -> GeometryFrame:
        """The working frame, its textured points and the tracks from the previous frame (tracking here balances the
        reader and flow threads: measured 85 -> 98 frames/s on two cores, clip 07); their essential fit is left
        to :meth:`complete`. Once the still tracks find a bonnet, the frames' view ends above its edge
        (:mod:`flowvo.odometry.view_bottom`): points and tracks stay above it, and so does the road. A still layer
        over the road (a reflection in the windshield, :mod:`flowvo.odometry.static_layer`) is taken out of the frame
        the road's flow is measured on."""
        working = super().prepare(image)
        previous = self._previous
        if previous is None:
            textured = textured_points(working)
            self._previous = GeometryFrame(working, textured, *(np.zeros((0, 2), np.float32),) * 4, None,
                                           landmarks=self._landmarks(working, textured))
            return self._previous
        continued_rows = np.arange(0, len(previous.tracked_next), CONTINUE_EVERY) if self.window else \
            np.zeros(0, np.int64)
        count = len(previous.textured_px)
        start = np.concatenate([previous.textured_px, previous.tracked_next[continued_rows]])
        bottom = previous.bottom_px  # the frames end above a bonnet found by then: tracks that go under it are lost,
        # as at the frame's edge
        moved, found = lucas_kanade(previous.image[:bottom], working[:bottom], start, TRACK_WINDOW_PX)  # one call:
        # each point is tracked alone
        tracked_prev, tracked_next = start[:count][found[:count]], moved[:count][found[:count]]
        steps_px = tracked_next - tracked_prev
        motion_px = row_norms(steps_px)
        self.still_tracks.observe(tracked_prev, motion_px)
        self.view_bottom.observe(working)
        bottom = self.view_bottom.settle(self.still_tracks.band_top_px())
        if self.view_bottom.found:
            self.static_layer.view_ends(bottom)
        below = motion_px[tracked_prev[:, 1] >= self.static_layer.region[0].start]  # the road's, and what stands on it
        self.static_layer.observe(working, bool(len(below)) and median(below) >= self.layer_moving_px, tracked_prev,
                                  steps_px)
        textured = textured_points(working[:bottom])
        if self.still_tracks.still_cells:  # no new tracks from a bonnet, a dashboard, a watermark
            textured = textured[self.still_tracks.keep(textured)]
        pair = self.road.undistort(tracked_prev), self.road.undistort(tracked_next)
        self._previous = GeometryFrame(working, textured, tracked_prev, tracked_next, *pair, None,
                                       continued_rows[found[count:]], moved[count:][found[count:]],
                                       self._landmarks(working, textured), fit_pending=True, bottom_px=bottom,
                                       road_image=self.static_layer.remove(working))
        return self._previous

    def complete(self, prepared: GeometryFrame) -> GeometryFrame:
        """The prepared frame with its pair's essential fit (:meth:`fit_motion`; the same in either thread: USAC's
        sampling is seeded at each call): the work a stream's reader and motion threads share by how busy they are
        (:func:`flowvo.drive.stream.stream_odometry`). All of it in the motion thread, clip 07 streamed at 0.27 of
        decoding; all in the reader thread 0.29-0.30; shared, up to 3 % faster, within the machine's drift."""
        if not prepared.fit_pending:
            return prepared
        return replace(prepared, pair_fit=self.fit_motion(prepared.pair_prev, prepared.pair_next), fit_pending=False)

    def _landmarks(self, working: np.ndarray, textured: np.ndarray) -> Landmarks | None:
        """``flowvo-ba``: the landmark tracks of the frame (None for the other methods)."""
        return None if self.landmark_tracker is None else self.landmark_tracker.advance(working, textured)

    def flow(self, previous: GeometryFrame, current: GeometryFrame) -> GeometryFlow:
        """Point tracks over the whole frame (from ``prepare``), the dense flow of the road crop from the
        road key frame (at a drive's start through the prediction :meth:`_swept_prediction` finds) and the key
        frames' tracks (see :class:`GeometryFlow`)."""
        current = self.complete(current)  # done already where a stream or flowvo.Odometry called it
        motion = current.pair_prev, current.pair_next, current.pair_fit
        key = previous if self.road_key.frame is None else self.road_key.frame
        bottom = min(key.bottom_px, current.bottom_px)  # where the two frames' view ends (a bonnet found)
        unpredicted = None
        if key is previous and self.road_key.prediction is None and self.speed.last_speed_mps is None and \
                current.pair_fit is not None:
            unpredicted = self.road.unpredicted(previous.road_image, current.road_image, bottom)
            grid_px = self.road.view(bottom).grid_undistorted_px
            if not road_flow_within_reach(row_norms(unpredicted - grid_px), self.dis_reach_px, predicted=False):
                self.road_key.prediction, unpredicted = self._swept_prediction(previous, current, bottom), None
        road = self.road.measure(key.road_image, current.road_image, self.road_key.prediction, unpredicted, bottom)
        key_tracks = (None, None) if key is previous else self._tracks_from(key, current)
        rotation_key = self.checks.rotation_key.frame
        rotation_tracks = (None, None) if rotation_key is None else \
            key_tracks if rotation_key is key else self._tracks_from(rotation_key, current)
        return GeometryFlow(*motion, *road, current, *key_tracks, *rotation_tracks)

    def _swept_prediction(self, previous: GeometryFrame, current: GeometryFrame, bottom_px: int) -> np.ndarray:
        """The road homography of the pair's motion at the one of ``ACQUISITION_STEPS`` whose warp matches the road
        best (:meth:`RoadFlow.best_prediction`; the road level under the camera's mounting, a camera height below
        it; the frames' view ending at ``bottom_px``): a drive's first road prediction, while its speed is not known
        and its road moved beyond DIS's reach."""
        normal = in_camera_frame(RoadPlane.level(KITTI_CAMERA_HEIGHT_M), self.road_length.levelling).normal
        fit = current.pair_fit
        return self.road.best_prediction(previous.road_image, current.road_image, [
            metric_road_homography(self.K, se3_next_prev(fit.R, fit.t_dir * length), normal, KITTI_CAMERA_HEIGHT_M)
            for length in ACQUISITION_STEPS], bottom_px)

    def _tracks_from(self, key: GeometryFrame, current: GeometryFrame) -> tuple[np.ndarray, np.ndarray]:
        """The key frame's textured points tracked into ``current``: where they were and went, undistorted."""
        bottom = min(key.bottom_px, current.bottom_px)  # where the two frames' view ends (a bonnet found)
        points = key.textured_px[key.textured_px[:, 1] < bottom]
        key_prev, key_next = track_points(key.image[:bottom], current.image[:bottom], points, TRACK_WINDOW_PX)
        return self.road.undistort(key_prev), self.road.undistort(key_next)

    def motion(self, times_s: tuple[float, float], previous: GeometryFrame, flow: GeometryFlow) -> np.ndarray:
        """``T_prev_cur`` of the step between ``times_s`` (previous, current), seconds: the per-pair estimate
        (the window stage, :meth:`refine`, may change its length). Its stages in order: the standstill test, the
        essential fit and its checks, the road plane and the next step's road key frame, the network where no
        road was seen for a while, the speed prior, and what the window needs of the step."""
        time_s, dt_s = times_s[1], times_s[1] - times_s[0]
        if not self._readout_checked:
            check_readout_within(self.camera.readout_ms, dt_s)
            self._readout_checked = True
        self.last_view = (time_s, flow, None, None)
        self._keep_landmarks(times_s[0], previous, time_s, flow.current)
        last_step, self._last_step, self._step_scale = self._last_step, None, None
        span = self.road_key.begin(previous, times_s[0], flow.key_prev is None)
        road_motion_px = row_norms(flow.road_next - flow.road_prev)
        road_moved_px = median(road_motion_px) if len(road_motion_px) else 0.0
        road_measured = road_flow_within_reach(road_motion_px, self.dis_reach_px, span.predicted, span.steps)
        step_px = self._step_motion_px(flow, road_moved_px / span.steps)
        still = step_px < self.still_flow_px * min(1.0, dt_s / STILL_SPAN_S)
        if still and self.speed.could_stand_at(time_s):
            return self._stand_still(time_s)
        # a car too fast to have stopped, with only distant scenery in view, is degenerate too
        fit = None if still else flow.motion_fit
        if fit is None:
            return motion_in_metres(self._keep_last_motion(dt_s), self.metres_per_unit)
        if step_px < self.still_flow_px:
            fit = key_fit = self._creeping(fit)
        else:
            road_key_fit = None if span.from_previous else self.fit_motion(flow.key_prev, flow.key_next)
            rotation_key_fit = None if flow.rotation_key_prev is None else road_key_fit \
                if flow.rotation_key_prev is flow.key_prev else self.fit_motion(flow.rotation_key_prev,
                                                                                 flow.rotation_key_next)
            fit = self.checks.checked(fit, rotation_key_fit, (flow.motion_prev, flow.motion_next), dt_s,
                                      self.speed.last_speed_mps)
            key_fit = fit if span.from_previous else road_key_fit
        self.checks.advance((times_s[0], previous), time_s, fit.R)
        last_speed_mps = self.speed.last_speed_mps
        self.road_length.advance(fit.R, dt_s, 0.0 if last_speed_mps is None else last_speed_mps * dt_s)  # the step at
        # the last speed: where along the drive the road measured ahead lies under the car (its own length comes later)
        taken = len(self.road_length.pitches_taken_deg)
        shares = None if not self.camera.readout_ms else baseline_shares(
            self.road.frame_rows(flow.road_prev), self.road.frame_rows(flow.road_next), self.working_hw[0],
            self.camera.readout_ms / 1000.0, time_s - span.start_s)
        plane, road_m = self.road_length.measure((flow.road_prev, flow.road_next), key_fit, road_measured, shares)
        mounting_taken = len(self.road_length.pitches_taken_deg) > taken
        if mounting_taken:  # the drive's mounting: the car's axes turn with it, and a camera found to look up, or
            # rolled, has its road crop and grid moved down where its horizon comes near them (RoadFlow.place)
            self.checks.turn_car_axes(self.road_length.levelling.T)
            self.road.place(self.road_length.pitch_deg, self.road_length.roll_deg, MIN_FLOW_SIDE_PX)
        road_share_m = None if road_m is None else road_m / span.steps  # this step's share, by the count of steps
        self.last_view = (time_s, flow, fit, plane)
        self.road_key.end(span, time_s, plane, road_moved_px, (key_fit, fit), road_m, self.speed.last_speed_mps)
        if road_m is not None and road_m > self.speed.max_speed_at(time_s) * (time_s - span.start_s):
            road_m = None  # faster than a car could have driven (a wrong plane): unmeasured, the network may step in
            self.road_too_fast_steps += 1
        step_m = None if road_m is None else road_m * dt_s / (time_s - span.start_s)  # per pair: this step's
        # share of the road since the key frame, at the speed it gives
        network_m = self._network_where_no_road(time_s, step_m is not None, previous, flow.current)
        step_m = step_m if network_m is None else network_m
        speed_mps = self.speed.update(time_s, None if step_m is None else step_m / dt_s)
        step_m = 0.0 if speed_mps is None else speed_mps * dt_s
        self.last_motion = invert_se3(se3_next_prev(fit.R, fit.t_dir * step_m))
        near_px = self.road_key.baseline_parallax_px(self.road_length.near_parallax_px / span.steps, plane is not None,
                                                     self.speed.last_speed_mps)
        # the step's length for the sliding key frame's prediction from the road's share of it where there is one: the
        # warp DIS sees must not depend on the timestamps' last bits (the speed prior's length does: a bag's stamps
        # against times.txt moved a drive's poses by 8e-4)
        slide_m = step_m if road_share_m is None else road_share_m
        self.road_key.slide(flow.current, time_s, se3_next_prev(fit.R, fit.t_dir * slide_m),
                            self.road_length.normal.normal, near_px, span,
                            self.road_length.noise.baseline_px(self.road_key.baseline_px))
        if self.window is not None:
            self._record_step(times_s, span, fit, (step_m, road_m, network_m), last_step, flow, mounting_taken)
        return motion_in_metres(self.last_motion, self.metres_per_unit)

    @staticmethod
    def _step_motion_px(flow: GeometryFlow, road_step_px: float) -> float:
        """How far the step moved the view (working pixels): the larger of the road's median motion per step
        (``road_step_px``) and the tracked points' median motion (the road's alone without tracks)."""
        moved_px = row_norms(flow.motion_next - flow.motion_prev)
        return max(road_step_px, median(moved_px)) if len(moved_px) else road_step_px

    def _creeping(self, fit: EssentialMotion) -> EssentialMotion:
        """A step shorter than a standstill's at 10 Hz (road and scene under ``STILL_FLOW_PX``) but too long for
        one at this frame rate: a car creeping (30 frames/s: under 1.8 m/s). Its tracks moved too little for an
        essential fit (on a generated drive at 30 frames/s such fits turned up to 0.12 degrees too far, and the yaw
        check then held that rate for four steps): the car moves along its forward axis, turning less than its
        tracks' half a pixel shows."""
        return EssentialMotion(np.eye(3), -self.checks.travel.forward, fit.inliers)

    def _stand_still(self, time_s: float) -> np.ndarray:
        """The road and the scene stand still (distant points alone can mislead): the identity, the speed
        history restarted at ``time_s``."""
        self.road_key.forget()
        self.checks.forget()
        self.speed.stop(time_s)
        self.last_motion = np.eye(4)
        return self.last_motion

    def _keep_last_motion(self, dt_s: float) -> np.ndarray:
        """No fit (degenerate): the last motion again (constant velocity), unmeasured."""
        self.road_key.forget()
        self.road_length.forget()
        self.checks.forget()
        T_next_prev = invert_se3(self.last_motion)
        length_m = float(np.linalg.norm(T_next_prev[:3, 3]))
        self._step_scale = StepScale(T_next_prev[:3, :3], T_next_prev[:3, 3] / max(length_m, 1e-12), length_m, dt_s)
        return self.last_motion

    def _network_where_no_road(self, time_s: float, road_seen: bool, previous: GeometryFrame,
                               current: GeometryFrame) -> float | None:
        """The network's distance (metres) where no trusted road was seen for a while and a network is there
        (:class:`NetworkFallbackPolicy`: the speed prior alone would drift), else None. Planes refused as tilted
        while the drive's mounting is pending (:meth:`RoadPlaneTally.mounting_pending`) are the road seen through a
        pitch not known yet: the steps wait for it (held, at a drive's start, until it measures them) instead of
        taking the network's distance, which the level cameras it learnt from leave 24 % long on a camera pitched 8
        degrees down (the first 20 steps of a generated drive run as if level)."""
        if road_seen or self.road_length.tally.mounting_pending():
            self.fallback_policy.road_seen(time_s)
            return None
        if self.fallback is not None and self.fallback_policy.network_needed(time_s):
            return self.fallback.distance_m(previous.image, current.image)
        return None

    def _record_step(self, times_s: tuple[float, float], span: RoadSpan[GeometryFrame], fit: EssentialMotion,
                     lengths_m: tuple[float, float | None, float | None],
                     last_step: tuple[EssentialMotion, np.ndarray, np.ndarray] | None, flow: GeometryFlow,
                     mounting_taken: bool) -> None:
        """What the window needs of the step (:class:`StepScale`): its motion, its per-pair length, the road's
        metres since the key frame and the network's (``lengths_m``), the ratio to the last step's length, and where
        the drive's mounting stands (in doubt; ``mounting_taken`` at this step)."""
        ratio = None if last_step is None else self._length_ratio(last_step, flow.current, fit)
        self._step_scale = StepScale(fit.R, fit.t_dir, lengths_m[0], times_s[1] - times_s[0], *lengths_m[1:],
                                     *((None, 0.0) if ratio is None else ratio), road_steps=span.steps,
                                     mounting_pending=self.road_length.tally.mounting_pending(),
                                     mounting_taken=mounting_taken)
        self._last_step = fit, flow.motion_prev, flow.motion_next

    def _keep_landmarks(self, previous_s: float, previous: GeometryFrame, time_s: float,
                        current: GeometryFrame) -> None:
        """``flowvo-ba``: the frames' landmark tracks, undistorted, until the bundle stage takes them."""
        if self.bundle is None:
            return
        first = None if self.bundle.started else (previous_s, self._undistorted_landmarks(previous))
        self.stage.keep_landmarks(first, (time_s, self._undistorted_landmarks(current)))

    def fit_motion(self, points_prev: np.ndarray, points_next: np.ndarray) -> EssentialMotion | None:
        """The motion up to scale from undistorted tracks (N, 2): USAC's essential fit, refitted robustly over its
        inliers (:func:`flowvo.odometry.two_view.refined_motion`); None where USAC finds none."""
        return essential_motion(points_prev, points_next, self.K, threshold_px=self.threshold_px,
                                robust_scale_px=self.robust_scale_px)

    def _length_ratio(self, last_step: tuple[EssentialMotion, np.ndarray, np.ndarray], current: GeometryFrame,
                      fit: EssentialMotion) -> LengthRatio | None:
        """This step's length over the last one's (:mod:`flowvo.odometry.scale_propagation`), from the last step's
        inlier tracks (its fit and undistorted tracks) that went on into ``current``."""
        last_fit, before, at = last_step
        inlier = last_fit.inliers[current.continued_rows]  # rows of the last step's tracks
        rows = current.continued_rows[inlier]
        return step_length_ratio((before[rows], at[rows]), last_fit, (at[rows], self.road.undistort(
            current.continued_next[inlier])), fit, self.K, self.min_parallax_px)

    def _undistorted_landmarks(self, frame: GeometryFrame) -> Landmarks:
        """The frame's landmark tracks in undistorted working pixels."""
        return Landmarks(frame.landmarks.ids, self.road.undistort(frame.landmarks.px))

    def measured(self) -> StepScale | None:
        """What the last :meth:`motion` measured of its step's length, for the window (None: a standstill)."""
        return self._step_scale

    def refine(self, time_s: float, motion: np.ndarray, measured: StepScale | None
               ) -> list[tuple[float, np.ndarray]]:
        """The window stage (:class:`WindowStage`): the step ending at ``time_s`` (``motion`` and what
        :meth:`measured` gave for it) goes into the scale window; the motions now final come back in metres,
        ``latency_frames`` late (per pair: at once)."""
        return [(time_s, motion)] if self.stage is None else self.stage.push(time_s, measured)

    def flush(self) -> list[tuple[float, np.ndarray]]:
        """The motions still in the window (and the bundle stage) at the end of the drive."""
        return [] if self.stage is None else self.stage.flush()

    def step_records(self) -> list[StepRecord] | None:
        """What became of each final step so far (the window's records, lengths in metres; None per pair)."""
        return None if self.stage is None else self.stage.records()

    def summary(self) -> dict:
        """How many steps took the network's distance (no trustworthy road plane for a while), how the road
        planes fared (:class:`RoadPlaneTally`) and how far their road flow erred
        (:class:`flowvo.odometry.road_noise.RoadFlowNoise`), how many steps at speed took the last direction of travel
        instead of the fit's (:mod:`flowvo.odometry.travel_direction`), how many took the last yaw rate instead of the
        fit's (:mod:`flowvo.odometry.yaw_rate`), how many steps' rotations were measured from an earlier key frame
        (:mod:`flowvo.odometry.rotation_key`), how many cells of the road grid and of the tracked points stood still
        at the end (a bonnet: :mod:`flowvo.odometry.still_regions`), the still layer over the road
        (:mod:`flowvo.odometry.static_layer`), how many measured speeds were refused as faster
        than a car could have driven (``speed_limit``: ``MAX_SPEED_MPS`` for a camera ``LOW_CAMERA_HEIGHT_M`` high, in
        proportion to the height, lower soon after a standstill), and the window stage's record
        (:meth:`WindowStage.summary`)."""
        kept = {"network_distance_steps": self.fallback_policy.network_steps} if self.fallback else {}
        kept["road_planes"] = self.road_length.tally.record() | self.road_length.profile.record() | \
            {"pitches_taken_deg": self.road_length.pitches_taken_deg,
             "rolls_taken_deg": self.road_length.rolls_taken_deg} | \
            self.road_length.noise.record(self.road_key.baseline_px, self.frame_rows / self.working_hw[0])
        kept.update(self.checks.summary())
        kept["still_regions"] = {"road_cells": self.road.still.still_cells,
                                 "track_cells": self.still_tracks.still_cells,
                                 "view_ends_at_row": self.view_bottom.frame_row(self.frame_rows)}
        kept["static_layer"] = self.static_layer.record()
        kept["speed_limit"] = {"max_speed_mps": self.speed.max_speed_mps * self.metres_per_unit,
                               "refused_measurements": self.speed.implausible_measurements + self.road_too_fast_steps}
        if self.stage is not None:
            kept.update(self.stage.summary())
        return kept

