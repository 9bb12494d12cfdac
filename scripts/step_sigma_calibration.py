"""Print how well the default method's step records (``NAME_steps.csv``) know their own uncertainty on the
real clips: per clip, the median recorded standard deviation of a step's log length, the rms of the log
of each step's length over the truth's, and the share of steps within one and two recorded sigmas of the
truth (a normal error would give 68 and 95 %). Steps the truth moves less than 0.2 m are left out (the
truth's own noise is then a large part of the error).

Usage: python scripts/step_sigma_calibration.py OUT [DATA_ROOT SEQUENCE ...]
(default: the three real clips, about 30 s; a synthetic replay, say ``/data/synth 08``, has an exact truth)
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT

from flowvo.drive.steps_csv import read_steps_csv
from flowvo.kitti.poses import read_kitti_poses

MIN_TRUE_STEP_M = 0.2


def row(data: Path, clip: str, out: Path) -> tuple[str, np.ndarray]:
    subprocess.run(["flowvo", "-q", "run", "--data", str(data), "--sequence", clip, "--out", str(out), "--force"],
                   check=True, capture_output=True)
    records = read_steps_csv(out / f"{clip}_steps.csv")
    truth = read_kitti_poses(data / "poses" / f"{clip}.txt").positions
    true_m = np.linalg.norm(np.diff(truth, axis=0), axis=1)
    kept = [(r.length_m, r.log_sigma, t) for r, t in zip(records, true_m, strict=True)
            if r.log_sigma is not None and t >= MIN_TRUE_STEP_M]
    length_m, sigma, t = (np.array(column) for column in zip(*kept, strict=True))
    error = np.log(length_m / t)
    z = np.abs(error) / sigma
    return (f"| {data.name} {clip} | {len(z)} | {100 * np.median(sigma):.2f} | {100 * np.sqrt(np.mean(error**2)):.2f}"
            f" | {100 * np.mean(z <= 1):.0f} | {100 * np.mean(z <= 2):.0f} |"), z


def main(out: Path, drives: list[tuple[Path, str]]) -> None:
    print("| drive | steps | median sigma % | rms error % | within 1 sigma % | within 2 sigmas % |")
    print("| --- | --- | --- | --- | --- | --- |")
    pooled = []
    for data, clip in drives:
        line, z = row(data, clip, out / f"{data.name}_{clip}")
        print(line, flush=True)
        pooled.append(z)
    z = np.concatenate(pooled)
    print(f"| all | {len(z)} | | | {100 * np.mean(z <= 1):.0f} | {100 * np.mean(z <= 2):.0f} |")


if __name__ == "__main__":
    arguments = sys.argv[2:]
    main(Path(sys.argv[1]), [(Path(arguments[i]), arguments[i + 1]) for i in range(0, len(arguments), 2)]
         if arguments else [(DEFAULT_CLIPS_ROOT, clip) for clip in CLIPS])
