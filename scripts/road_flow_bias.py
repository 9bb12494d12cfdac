"""Print how well the default method's road flow and point tracks measure motions that are known exactly.

Real KITTI clip frames (their images only: no ground truth enters) are warped by the homography of a flat
road under a chosen motion (a step forward, then a yaw; the camera 1.65 m above the road) at full
resolution, then both frames go to the working width as the default method prepares them. Two tables:

- the road: the step length from the default method's road flow and road plane, given the exact motion
  (:meth:`FlowGeometryStep.road_flow`, :func:`flowvo.odometry.road_scale.trusted_road_plane`), against the chosen
  length, without a prediction and with predictions that are exact or off in length or yaw;
- the tracks: Lucas-Kanade as the default method tracks, under a pure yaw, the tracked motion against the
  exact one.

Cells: median error in % over the frames (in brackets: the smallest and largest).

Usage: python scripts/road_flow_bias.py [CLIPS_ROOT]
"""

import sys
from pathlib import Path

import cv2
import numpy as np
from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT

from flowvo.drive.options import RunOptions, open_drive
from flowvo.geometry import so3_exp
from flowvo.methods.base import WorkingFrames
from flowvo.methods.flowvo import TRACK_WINDOW_PX, FlowGeometryStep
from flowvo.odometry.road_plane import RoadPlane
from flowvo.odometry.road_scale import road_homography, trusted_road_plane
from flowvo.odometry.two_view import EssentialMotion, lucas_kanade, textured_points

CAMERA_HEIGHT_M = 1.65
FRAMES_PER_CLIP = 12  # every 8th frame of the clip
# (step m, yaw deg, prediction: None, or (its length over the true one, its yaw error in deg))
ROAD_CASES = [(step_m, yaw_deg, prediction) for step_m, yaw_deg in ((0.5, 0.0), (1.0, 0.0), (2.0, 0.0), (1.0, 1.0))
              for prediction in (None, (1.0, 0.0), (1.05, 0.0), (0.95, 0.0), (1.0, 0.3))]
TRACK_YAWS_DEG = (0.2, 0.5, 1.0, 2.0)


def road_motion(step_m: float, yaw_rad: float) -> EssentialMotion:
    """The camera moves ``step_m`` along its optical axis, then turns by ``yaw_rad`` (to the right):
    ``R_next_prev`` and the unit translation, in the next camera's frame."""
    R = so3_exp(np.array([0.0, yaw_rad, 0.0]))
    t = -R @ np.array([0.0, 0.0, step_m])
    return EssentialMotion(R, t / step_m, np.ones(1, bool))


def flat_road_homography(K: np.ndarray, step_m: float, yaw_rad: float) -> np.ndarray:
    """Pixels of the flat road (``CAMERA_HEIGHT_M`` below the first camera) in the first frame -> the second."""
    plane = RoadPlane.level(CAMERA_HEIGHT_M / step_m)  # distance in step lengths
    return road_homography(K, road_motion(step_m, yaw_rad), plane)


def warped_pair(step: WorkingFrames, image: np.ndarray, K_full: np.ndarray, homography_full: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The working frames of ``image`` and of ``image`` moved by a full-resolution homography."""
    moved = cv2.warpPerspective(image, homography_full, image.shape[::-1], flags=cv2.INTER_LANCZOS4,
                                borderMode=cv2.BORDER_REPLICATE)
    return WorkingFrames.prepare(step, image), WorkingFrames.prepare(step, moved)


def road_length_errors(step: FlowGeometryStep, images: list[np.ndarray], K_full: np.ndarray, step_m: float,
                       yaw_deg: float, prediction: tuple[float, float] | None) -> np.ndarray:
    """Relative error of the road's step length per image (NaN where no plane is trusted)."""
    yaw_rad = np.radians(yaw_deg)
    predicted = None if prediction is None else flat_road_homography(step.K, step_m * prediction[0],
                                                                     yaw_rad + np.radians(prediction[1]))
    errors = []
    for image in images:
        previous, current = warped_pair(step, image, K_full, flat_road_homography(K_full, step_m, yaw_rad))
        road = step.road.measure(previous, current, predicted)
        plane = trusted_road_plane(*road, step.K, road_motion(step_m, yaw_rad))
        errors.append(np.nan if plane is None else CAMERA_HEIGHT_M / plane.distance / step_m - 1.0)
    return np.array(errors)


def track_errors(step: FlowGeometryStep, images: list[np.ndarray], K_full: np.ndarray, yaw_deg: float
                 ) -> np.ndarray:
    """Per image, the median relative error of the tracked motion along the exact one under a pure yaw."""
    rotation = so3_exp(np.array([0.0, np.radians(yaw_deg), 0.0]))
    errors = []
    for image in images:
        previous, current = warped_pair(step, image, K_full, K_full @ rotation @ np.linalg.inv(K_full))
        start = textured_points(previous)
        moved, found = lucas_kanade(previous, current, start, TRACK_WINDOW_PX)
        exact = cv2.perspectiveTransform(start.reshape(-1, 1, 2).astype(np.float64),
                                         step.K @ rotation @ np.linalg.inv(step.K)).reshape(-1, 2)
        inside = found & (exact[:, 0] > 10) & (exact[:, 0] < step.working_hw[1] - 10)
        true, measured = exact[inside] - start[inside], moved[inside] - start[inside]
        errors.append(np.median((measured * true).sum(axis=1) / (true * true).sum(axis=1)) - 1.0)
    return np.array(errors)


def cell(errors: np.ndarray) -> str:
    """``median [min, max]`` in %, with the count of frames without a value."""
    if np.isnan(errors).all():
        return "none"
    text = f"{100 * np.nanmedian(errors):+.2f} [{100 * np.nanmin(errors):+.1f}, {100 * np.nanmax(errors):+.1f}]"
    return text + (f", {np.isnan(errors).sum()} none" if np.isnan(errors).any() else "")


def main(root: Path) -> None:
    clips = {}
    for clip in CLIPS:
        drive = open_drive(RunOptions(out="", data=str(root), sequence=clip))
        images = [image for _, image in drive.source.frames()][::8][:FRAMES_PER_CLIP]
        clips[clip] = (FlowGeometryStep(drive.camera, drive.source.image_size_hw), images, drive.camera.intrinsics.K)
    print("| road motion | prediction | " + " | ".join(f"clip {clip}" for clip in clips) + " |")
    print("| --- | --- |" + " --- |" * len(clips))
    for step_m, yaw_deg, prediction in ROAD_CASES:
        name = "none" if prediction is None else \
            f"length {100 * (prediction[0] - 1):+.0f} %, yaw {prediction[1]:+.1f} deg"
        cells = [cell(road_length_errors(step, images, K, step_m, yaw_deg, prediction))
                 for step, images, K in clips.values()]
        print(f"| {step_m:g} m, yaw {yaw_deg:g} deg | {name} | " + " | ".join(cells) + " |", flush=True)
    print("cells: the road's step length against the exact one, % (median [min, max] over the frames)\n")
    print("| pure yaw | " + " | ".join(f"clip {clip}" for clip in clips) + " |")
    print("| --- |" + " --- |" * len(clips))
    for yaw_deg in TRACK_YAWS_DEG:
        cells = [cell(track_errors(step, images, K, yaw_deg)) for step, images, K in clips.values()]
        print(f"| {yaw_deg:g} deg | " + " | ".join(cells) + " |", flush=True)
    print("cells: the tracked motion along the exact one, % (median over the tracks, then over the frames)")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_CLIPS_ROOT)
