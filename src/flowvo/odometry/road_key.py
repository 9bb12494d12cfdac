"""The road key frame: where a step's road flow starts, and the prediction of that flow.

Where the road moved little (slow driving) a step keeps its start frame as the road key frame, up to
``MAX_ROAD_KEY_S`` back, so that the next step measures the road over a longer baseline; where the last step
found the road plane, the next step's road flow is predicted by that plane under the motion so far (constant
velocity), and DIS measures only the residual (:class:`flowvo.odometry.road_flow.RoadFlow`). Where one step
moves the near road less than ``BASELINE_PX`` beyond the rotation, the next step's road is measured from the
frame as many steps back as that baseline takes (:meth:`RoadKeyFrame.slide`): a sliding key frame, its flow
predicted through the steps since; after a refused plane only for a slow car whose road moved too little for one
(:meth:`RoadKeyFrame.baseline_parallax_px`). A drive whose road flow is noisy needs a longer baseline, and there a step
whose unpredicted flow found no road has the next one predicted (:mod:`flowvo.odometry.road_noise`).

Times in seconds; pixels of the working frame (thresholds given at :data:`REFERENCE_WIDTH_PX` and scaled);
homographies on undistorted working pixels; lengths in metres.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np

from flowvo.odometry.road_plane import RoadPlane
from flowvo.odometry.road_scale import metric_road_homography, onward_road_homography, road_homography
from flowvo.odometry.two_view import EssentialMotion

DIS_REACH_PX = 12.0  # at the reference width: road motion DIS follows without a prediction; beyond, it
# under-estimates it (one step's near road decides, a key frame's span its median: road_scale.road_flow_within_reach)
KEY_ROAD_PX = DIS_REACH_PX / 2  # a step whose road moved less keeps its road key frame, so the road scale is
# measured over a longer baseline (two such steps stay within DIS's reach;
# synthetic 30 frames/s drive: 8.4 -> 3.0 %, the same drive at 10: 3.2 -> 3.0 %; real clip 01 1.30 -> 1.10 %)
MAX_ROAD_KEY_S = 0.5  # a road key frame older than this is replaced even when the road moved little
MAX_KEY_PREDICTION_SPEED_MPS = 6.0  # below it a kept road key frame's flow is predicted too (as the previous
# frame's is): clip 07 over working widths 1.63 -> 1.47 % (median); at any speed as good, but earlier a wrong
# two-step plane at 12 m/s passed every gate on a generated drive
BASELINE_PX = DIS_REACH_PX  # at the reference width: the near road's parallax (90th percentile of the road
# points' motion beyond the rotation) a road flow should span. One step of real KITTI 03 at 6-9 m/s moves it 8-14 px,
# and its road lengths came out 2 % short there (its path -2.0 %, t_err 2.17 %), 0.7 % at 5 Hz: the road is then
# measured from the frame ceil(BASELINE_PX / per-step parallax) steps back (sliding, at most MAX_ROAD_KEY_S):
# 03 1.13 %, path -1.0 %; 10 px 1.64 %, 14 px 1.11 %, 18 px 1.06 % but clip 01 (16-29 px a step) 1.10 -> 1.89 %
TIME_TOLERANCE_S = 1e-6  # timestamps from different containers differ in their last bits (0.3 against
# 0.30000000000000004): an age compared with MAX_ROAD_KEY_S must not depend on them

Frame = TypeVar("Frame")


@dataclass(frozen=True)
class RoadSpan(Generic[Frame]):
    """What one step's road flow spans: from ``frame`` (the road key frame, or the step's previous frame when
    ``from_previous``) at ``start_s`` over ``steps`` steps, ``predicted`` when its flow went through a predicted
    homography."""

    frame: Frame
    start_s: float
    steps: int
    predicted: bool
    from_previous: bool


class RoadKeyFrame(Generic[Frame]):
    """The road key frame of a stream of steps (module docstring): ``frame`` is where the next step's road flow
    starts (None: the previous frame), ``prediction`` the road homography that flow is measured through (None:
    measured as it is). ``key_road_px``: the road motion (working pixels, median) under which a key frame is
    kept; ``camera_height_m``: the road's distance below the camera; ``baseline_px``: the near road's parallax a
    road flow should span at least (0: none, every step measures its road from its previous frame or a kept key frame;
    :meth:`slide` may be given more)."""

    def __init__(self, K: np.ndarray, key_road_px: float, camera_height_m: float, baseline_px: float = 0.0) -> None:
        self.K, self.key_road_px, self.camera_height_m = K, key_road_px, camera_height_m
        self.frame: Frame | None = None
        self.prediction: np.ndarray | None = None
        self._start_s, self._steps = 0.0, 0
        self.baseline_px = baseline_px
        self._recent: deque[tuple[Frame, float, np.ndarray]] = deque()  # (frame, time_s, T_next_prev of the step
        # that ended there, metres) of the frames a sliding key frame may start from

    def begin(self, previous: Frame, previous_s: float, from_previous: bool) -> RoadSpan[Frame]:
        """The span of the step that starts at frame ``previous`` (at ``previous_s``), its road flow measured
        ``from_previous`` or from the key frame; by default the next step starts from this step's frame,
        unpredicted (see :meth:`end`)."""
        if from_previous:
            span = RoadSpan(previous, previous_s, 1, self.prediction is not None, True)
        else:
            span = RoadSpan(self.frame, self._start_s, self._steps + 1, self.prediction is not None, False)
        self.frame, self.prediction = None, None
        return span

    def end(self, span: RoadSpan[Frame], time_s: float, plane: RoadPlane | None, road_moved_px: float,
            motions: tuple[EssentialMotion, EssentialMotion], road_m: float | None,
            last_speed_mps: float | None) -> None:
        """After the step ending at ``time_s`` whose road over ``span`` gave ``plane`` (in the key frame's
        camera frame; None: no trusted plane) and ``road_m`` metres since the key frame, its median road point
        moving ``road_moved_px``; ``motions``: (the key frame's to the current frame, the step's), up to scale.
        Where the road moved too little for a precise scale, the next step measures from the same key frame
        (predicted below ``MAX_KEY_PREDICTION_SPEED_MPS``); else, where this step's flow started at the previous
        frame and found the road, the next step's flow is predicted by this step's plane and motion."""
        if plane is None:
            return
        key_motion, step_motion = motions
        key_young = time_s - span.start_s < MAX_ROAD_KEY_S - TIME_TOLERANCE_S
        if road_moved_px < self.key_road_px and key_young:
            self.frame, self._start_s, self._steps = span.frame, span.start_s, span.steps
            if last_speed_mps is not None and last_speed_mps < MAX_KEY_PREDICTION_SPEED_MPS:
                # this step's share of the road by the count of steps, not by time: the warp DIS sees must not
                # depend on the timestamps' last bits (a bag's stamps against times.txt: 2 % apart otherwise)
                self.prediction = onward_road_homography(self.K, plane, key_motion, road_m, step_motion,
                                                         road_m / span.steps, self.camera_height_m)
        elif span.from_previous:
            self.prediction = road_homography(self.K, step_motion, plane)

    def forget(self) -> None:
        """No motion was measured (a standstill, a step without a fit): no sliding key frame before the next step."""
        self._recent.clear()

    def baseline_parallax_px(self, near_px: float, trusted: bool, last_speed_mps: float | None) -> float:
        """The near road's parallax per step (working pixels) :meth:`slide` takes after a step whose road moved its
        near points ``near_px`` beyond the rotation, its plane ``trusted`` or refused, the car last at
        ``last_speed_mps`` (the speed prior's units). A refused plane's counts only where the road moved under
        ``key_road_px`` and the car was slower than ``MAX_KEY_PREDICTION_SPEED_MPS``: a crawling car measuring its road
        one step at a time (1-4 px) would never find a plane again. Otherwise 0, no sliding key frame: a plane refused
        at speed is a road that is no plane, not a baseline too short."""
        if trusted:
            return near_px
        slow = last_speed_mps is not None and last_speed_mps < MAX_KEY_PREDICTION_SPEED_MPS
        return near_px if slow and near_px < self.key_road_px else 0.0

    def slide(self, current: Frame, time_s: float, T_next_prev: np.ndarray, normal: np.ndarray | None,
              near_px_per_step: float, span: RoadSpan[Frame], baseline_px: float | None = None) -> None:
        """After the step over ``span`` ending at frame ``current`` (``time_s``) with the metric motion ``T_next_prev``
        (4x4, the step's own length estimate) whose road moved its near points ``near_px_per_step`` beyond the rotation
        (:meth:`baseline_parallax_px`; 0: none): where that is less than ``baseline_px`` (None: the fixed one; more
        where the drive's road flow is noisy, :class:`flowvo.odometry.road_noise.RoadFlowNoise`), and :meth:`end` kept
        no key frame, the next step measures the road from the frame ``ceil(baseline_px / near_px_per_step)`` steps
        before it (at most ``MAX_ROAD_KEY_S`` back), its flow predicted by the road's ``normal`` (current frame; None:
        no prediction, no sliding key frame) ``camera_height_m`` below that frame under the steps since and this one
        again.

        Where the road needs more than the fixed baseline and this step's road flow, measured without a prediction,
        found no trusted plane, the next step's flow is predicted by the road's normal under this step's motion: a
        noisy road's unpredicted flow rarely finds the road again (the real dash-cam: 190 of its 199 road flows
        unpredicted, 82 planes trusted; real KITTI's road never needs more than the fixed baseline)."""
        self._recent.append((current, time_s, T_next_prev))
        dt_s = time_s - self._recent[-2][1] if len(self._recent) > 1 else 0.0
        while len(self._recent) > 1 and time_s + dt_s - self._recent[0][1] > MAX_ROAD_KEY_S + TIME_TOLERANCE_S:
            self._recent.popleft()
        needed_px = self.baseline_px if baseline_px is None else baseline_px
        if self.frame is not None or normal is None:
            return
        if near_px_per_step <= 0.0:
            if needed_px > self.baseline_px and not span.predicted:
                self.prediction = metric_road_homography(self.K, T_next_prev, normal, self.camera_height_m)
            return
        if near_px_per_step >= needed_px:
            return
        steps = min(len(self._recent), int(np.ceil(needed_px / near_px_per_step)))
        if steps < 2:
            return
        recent = list(self._recent)[-steps:]
        T_current_key = np.eye(4)
        for _, _, T_step in recent[1:]:
            T_current_key = T_step @ T_current_key
        self.frame, self._start_s, _ = recent[0]
        self._steps = steps - 1
        self.prediction = metric_road_homography(self.K, T_next_prev @ T_current_key,
                                                 T_current_key[:3, :3].T @ normal, self.camera_height_m)
