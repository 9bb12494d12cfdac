"""How far the scale window's measurements lie from the truth, by how far their steps turn (degrees a step), on the
real clips at 10 Hz and at every second frame (5 Hz):

- the three-view ratios, by the larger rotation of their two steps: the rms and mean error of each ratio's log
  against the truth's and the median of the ratios' own standard errors, in % (the measurement behind the scale
  window's ``RATIO_SIGMA_PER_DEG``);
- the road lengths (each trusted plane's metres since its road key frame, before the window), by the rotation of
  the step that measured them: the rms and mean error of their log against the truth's length of the same steps,
  in % (the measurement behind ``ROAD_SIGMA``, one sigma at every turn).

Usage: python scripts/measurement_error_by_turn.py OUT_DIR [CLIPS_ROOT]   (writes the 5 Hz clips to OUT_DIR/data)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT
from frame_rate_clips import subsample_clip

from flowvo.drive.options import RunOptions, open_drive
from flowvo.drive.stream import stream_odometry
from flowvo.methods.flowvo import FlowGeometryStep
from flowvo.odometry.scale_window import ScaleWindow

TURN_EDGES_DEG = (0.0, 1.0, 2.0, 3.0, 5.0, 180.0)


class MeasurementRecordingStep(FlowGeometryStep):
    """The default method's geometry, recording what each step measured for the window (time, StepScale)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.records = []

    def motion(self, times_s, previous, flow):
        motion = super().motion(times_s, previous, flow)
        self.records.append((times_s[1], self.measured()))
        return motion


def measurement_errors(data: Path, clip: str) -> tuple[np.ndarray, np.ndarray]:
    """Of ``clip``: per ratio (larger turn of its two steps in deg, log error against the truth in %, its own
    standard error in %), and per road length (its step's turn in deg, log error against the truth in %)."""
    drive = open_drive(RunOptions(out="", data=str(data), sequence=clip))
    source = drive.source
    step = MeasurementRecordingStep(drive.camera, source.image_size_hw, window=ScaleWindow())
    result = stream_odometry(source.frames(), step, source.frame_count, label=clip)
    index = {float(t): k for k, t in enumerate(result.timestamps_s)}
    lengths = np.linalg.norm(np.diff(source.ground_truth.T_world_cam[:, :3, 3], axis=0), axis=1)  # [k-1]: step k
    ratios, roads, last = [], [], None
    for time_s, scale in step.records:
        k = index[float(time_s)]
        if scale is not None and scale.ratio is not None and last is not None and last[0] == k - 1:
            turn_deg = max(last[1].turn_deg, scale.turn_deg)
            error = np.log(scale.ratio / (lengths[k - 1] / lengths[k - 2]))
            ratios.append((turn_deg, 100.0 * error, 100.0 * scale.ratio_log_sigma))
        if scale is not None and scale.road_m is not None:
            true_m = lengths[k - scale.road_steps : k].sum()
            roads.append((scale.turn_deg, 100.0 * np.log(scale.road_m * step.metres_per_unit / true_m)))
        last = None if scale is None else (k, scale)
    return np.array(ratios).reshape(-1, 3), np.array(roads).reshape(-1, 2)


def _table(title: str, columns: str, rates: dict[str, np.ndarray]) -> None:
    """One markdown table: per turn band and rate, the count, rms and mean of column 1 and, where there is a
    column 2 (the ratios' own standard errors), its median."""
    print(f"| turn a step | rate | {title} | rms error % | mean error % |{columns}")
    print("| --- | --- | --- | --- | --- |" + (" --- |" if columns else ""))
    for low, high in zip(TURN_EDGES_DEG[:-1], TURN_EDGES_DEG[1:], strict=True):
        for rate, errors in rates.items():
            inside = errors[(errors[:, 0] >= low) & (errors[:, 0] < high)]
            if len(inside):
                own = f" {np.median(inside[:, 2]):.2f} |" if columns else ""
                print(f"| {low:g}-{high:g} deg | {rate} | {len(inside)} | {np.sqrt(np.mean(inside[:, 1] ** 2)):.2f} | "
                      f"{inside[:, 1].mean():+.2f} |{own}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("clips", type=Path, nargs="?", default=DEFAULT_CLIPS_ROOT)
    args = parser.parse_args()
    for clip in CLIPS:
        subsample_clip(args.clips, clip, args.out / "data", 2)
    measured = {"10 Hz": [measurement_errors(args.clips, clip) for clip in CLIPS],
                "5 Hz": [measurement_errors(args.out / "data", clip) for clip in CLIPS]}
    _table("ratios", " own standard error % (median) |",
           {rate: np.concatenate([ratios for ratios, _ in runs]) for rate, runs in measured.items()})
    print()
    _table("road lengths", "", {rate: np.concatenate([roads for _, roads in runs]) for rate, runs in measured.items()})
    print(f"real KITTI clips {', '.join(CLIPS)} against their ground truth")


if __name__ == "__main__":
    main()
