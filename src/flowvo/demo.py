"""``flowvo demo``: render a held-out synthetic drive (or take the user's KITTI sequence), run the default
method, the thesis CNN and the classical baseline on it, evaluate them and write the report."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flowvo.drive.options import RunOptions
from flowvo.drive.run import run
from flowvo.errors import FlowvoError
from flowvo.kitti.sequence import KittiSequence
from flowvo.metrics.kitti_odometry import SEGMENT_LENGTHS_M, trajectory_distances
from flowvo.report.page import write_report
from flowvo.synth.dataset import synthesize

DEMO_SEED = 2026  # the packaged model's training worlds use seed 0: this world and path are unseen
DEMO_FRAMES = 900
DEMO_SCALE = 0.5
SHORT_DRIVE_LENGTHS_M = (10.0, 20.0, 30.0, 40.0, 50.0)  # sub-paths for drives under the devkit's shortest
DEMO_MAX_SPEED_MPS = 15.0  # an urban drive, like the KITTI trajectories the packaged model learned from


def demo(out: str | Path = "runs/demo", data: str | Path | None = None, sequence: str | None = None,
         model: str | Path | None = None, frames: int = DEMO_FRAMES, force: bool = False,
         camera_height_m: float | None = None) -> tuple[Path, list[dict]]:
    """Run the whole product once; returns the report's index.html and the run summaries (default method
    first). A second demo into the same ``out`` reuses what the first made with the same settings: the
    rendered drive, and every complete run (:func:`flowvo.batch.done.read_drive_outputs`) of the same drive
    and options, then writes the report of them again; a run made with other settings (another
    ``--camera-height``, ``--model``, drive) is refused unless ``force``, which replaces the runs and the
    report. ``camera_height_m`` overrides the sequence's camera height (metres)."""
    out = Path(out)
    if data is None:
        data, sequence = out / "data", "00"
        synthesize(data, [sequence], seed=DEMO_SEED, frames=frames, scale=DEMO_SCALE, max_speed_mps=DEMO_MAX_SPEED_MPS,
                   force=force)
    elif sequence is None:
        raise FlowvoError("with --data, also give --sequence NN")
    kitti_sequence = KittiSequence(data, sequence)
    has_gt = kitti_sequence.has_poses
    lengths_m = drive_lengths(kitti_sequence.poses.positions) if has_gt else SEGMENT_LENGTHS_M
    methods = [("flowvo", {}), ("cnn", {"model": str(model) if model else None}), ("classical", {})]
    if has_gt:
        methods.append(("classical", {"classical_scale": "gt"}))
    runs, folders, reused = [], [], []
    for method, extra in methods:
        folder = out / (method if extra.get("classical_scale") != "gt" else "classical_gt_scale")
        options = RunOptions(out=str(folder), data=str(data), sequence=sequence, method=method, force=force,
                             lengths_m=lengths_m, camera_height_m=camera_height_m, **extra)
        earlier = None if force else earlier_run(options)
        runs.append(earlier if earlier is not None else run(options))
        folders.append(folder)
        reused.append(earlier is not None)
    return write_report(folders, out / "report", force or any(reused)), runs


def earlier_run(options: RunOptions) -> dict | None:
    """The run.json of a complete earlier run in ``options.out`` of the same drive with the same options and
    library versions (it is reused); None when there is none, it is incomplete, or it ran another checkpoint
    than the packaged one (run.json does not say which: it is run, and refused without ``force``)."""
    from flowvo.batch.done import read_drive_outputs, recorded_difference
    from flowvo.batch.spec import processing_settings
    from flowvo.versions import library_versions

    if options.model is not None:
        return None
    try:
        outputs = read_drive_outputs(options.out)
    except FlowvoError:
        return None
    same_drive = outputs.run.get("data") == str(Path(options.data).resolve()) and \
        outputs.run.get("sequence") == KittiSequence(options.data, options.sequence).sequence
    if not same_drive or outputs.run.get("versions") != library_versions() or \
            recorded_difference(outputs.run, processing_settings(options)) is not None:
        return None
    return outputs.run


def drive_lengths(gt_positions: np.ndarray) -> tuple[float, ...]:
    """The devkit's sub-path lengths, or :data:`SHORT_DRIVE_LENGTHS_M` for a drive (camera centres (N, 3),
    metres) shorter than the devkit's shortest, whose KITTI metric would otherwise be empty."""
    path_m = float(trajectory_distances(gt_positions)[-1])
    return SEGMENT_LENGTHS_M if path_m >= SEGMENT_LENGTHS_M[0] else SHORT_DRIVE_LENGTHS_M


def summary_lines(runs: list[dict]) -> list[str]:
    """One terminal line per run: method, t_err, r_err (or ATE for short drives), frames per second."""
    lines = []
    width = max((len(summary["label"]) for summary in runs), default=0)
    for summary in runs:
        metrics = summary.get("metrics") or {}
        if metrics.get("t_err_percent") is not None:
            accuracy = f"t_err {metrics['t_err_percent']:5.2f} %  r_err {metrics['r_err_deg_per_m']:.4f} deg/m"
        elif metrics:
            accuracy = f"ATE {metrics['ate_rmse_m']:.2f} m (path shorter than the sub-paths: no KITTI t_err)"
        else:
            accuracy = "no ground truth"
        lines.append(f"{summary['label']:{width}s} {accuracy}  {summary['frames_per_second']:6.1f} frames/s")
    return lines
