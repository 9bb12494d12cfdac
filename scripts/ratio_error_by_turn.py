"""How far the default method's three-view ratios lie from the truth's, by how far their two steps turn (the
larger rotation of the two, degrees a step): on the real clips at 10 Hz and at every second frame (5 Hz), the
rms and mean error of each ratio's log against the truth's and the median of the ratios' own standard
errors, in %. The measurement behind the scale window's ``RATIO_SIGMA_PER_DEG``.

Usage: python scripts/ratio_error_by_turn.py OUT_DIR [CLIPS_ROOT]   (writes the 5 Hz clips to OUT_DIR/data)
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


class RatioRecordingStep(FlowGeometryStep):
    """The default method's geometry, recording what each step measured for the window (time, StepScale)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.records = []

    def motion(self, times_s, previous, flow):
        motion = super().motion(times_s, previous, flow)
        self.records.append((times_s[1], self.measured()))
        return motion


def ratio_errors(data: Path, clip: str) -> np.ndarray:
    """Per ratio of ``clip``: (larger turn of its two steps in deg, log error against the truth in %, its own
    standard error in %)."""
    drive = open_drive(RunOptions(out="", data=str(data), sequence=clip))
    source = drive.source
    step = RatioRecordingStep(drive.camera, source.image_size_hw, window=ScaleWindow())
    result = stream_odometry(source.frames(), step, source.frame_count, label=clip)
    index = {float(t): k for k, t in enumerate(result.timestamps_s)}
    lengths = np.linalg.norm(np.diff(source.ground_truth.T_world_cam[:, :3, 3], axis=0), axis=1)  # [k-1]: step k
    rows, last = [], None
    for time_s, scale in step.records:
        k = index[float(time_s)]
        if scale is not None and scale.ratio is not None and last is not None and last[0] == k - 1:
            turn_deg = max(last[1].turn_deg, scale.turn_deg)
            error = np.log(scale.ratio / (lengths[k - 1] / lengths[k - 2]))
            rows.append((turn_deg, 100.0 * error, 100.0 * scale.ratio_log_sigma))
        last = None if scale is None else (k, scale)
    return np.array(rows).reshape(-1, 3)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("clips", type=Path, nargs="?", default=DEFAULT_CLIPS_ROOT)
    args = parser.parse_args()
    for clip in CLIPS:
        subsample_clip(args.clips, clip, args.out / "data", 2)
    rates = {"10 Hz": np.concatenate([ratio_errors(args.clips, clip) for clip in CLIPS]),
             "5 Hz": np.concatenate([ratio_errors(args.out / "data", clip) for clip in CLIPS])}
    print("| turn a step | rate | ratios | rms error % | mean error % | own standard error % (median) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for low, high in zip(TURN_EDGES_DEG[:-1], TURN_EDGES_DEG[1:], strict=True):
        for rate, errors in rates.items():
            inside = errors[(errors[:, 0] >= low) & (errors[:, 0] < high)]
            if len(inside):
                print(f"| {low:g}-{high:g} deg | {rate} | {len(inside)} | {np.sqrt(np.mean(inside[:, 1] ** 2)):.2f} | "
                      f"{inside[:, 1].mean():+.2f} | {np.median(inside[:, 2]):.2f} |")
    print("real KITTI clips 01, 06, 07 against their ground truth")


if __name__ == "__main__":
    main()
