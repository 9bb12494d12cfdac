"""``flowvo run``: odometry on one sequence, learned or classical, with per-stage timing and evaluation.

Outputs in DIR: ``NN.txt`` (KITTI poses), ``NN.tum``, ``timing.json`` (seconds per frame for image read,
flow, network, chaining and total), ``run.json`` (what ran, on what data) and, when ground truth exists,
``eval_NN/`` (metrics.json and plots, as ``flowvo eval`` writes them).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import torch

from flowvo.atomic import write_json_atomic
from flowvo.classical_vo import classical_motions
from flowvo.errors import FlowvoError
from flowvo.evaluation import evaluate, save_evaluation
from flowvo.flow.cache import FlowCache
from flowvo.flow.cache_root import default_cache_root
from flowvo.flow.registry import create_estimator
from flowvo.geometry import chain_se3, planar_targets
from flowvo.kitti.poses import write_kitti_poses, write_tum_trajectory
from flowvo.kitti.sequence import KittiSequence
from flowvo.model.checkpoint import load_model
from flowvo.model.data import load_network_flows
from flowvo.model.inference import chain_motions, predict_targets, temporal_median
from flowvo.outputs import prepare_output_dir, run_outputs
from flowvo.trajectory import Trajectory


@dataclass
class RunOptions:
    """How to run: ``method`` is "learned" (needs ``model``) or "classical" (scale "gt" or "height")."""

    data: str
    sequence: str
    out: str
    method: str = "learned"
    model: str | None = None
    flow_method: str | None = None
    flow_scale: float | None = None
    flow_cache: str | None = None
    flow_weights: str | None = None
    median_window: int = 1
    classical_scale: str = "gt"
    device: str = "cpu"
    label: str | None = None
    force: bool = False  # replace the earlier result of this sequence in ``out`` (else refused)


def run(options: RunOptions) -> dict:
    """Run odometry and write every output; returns the run summary (also in run.json)."""
    sequence = KittiSequence(options.data, options.sequence)
    sequence.require_frames(2, "odometry")
    out = prepare_output_dir(options.out, run_outputs(sequence.sequence), options.force, dataset=options.data)
    if options.method == "learned":
        poses, timing, details = _run_learned(sequence, options)
    elif options.method == "classical":
        poses, timing, details = _run_classical(sequence, options)
    else:
        raise ValueError(f"unknown method {options.method!r}")
    trajectory = Trajectory.from_poses(poses)
    write_kitti_poses(out / f"{sequence.sequence}.txt", trajectory)
    write_tum_trajectory(out / f"{sequence.sequence}.tum", trajectory, sequence.times_s)
    frames = len(sequence)
    per_frame = {key: value / frames for key, value in timing.items()}
    per_frame["total"] = sum(per_frame.values())
    timing_report = {
        "seconds_per_frame": per_frame,
        "frames": frames,
        "frames_per_second": 1.0 / per_frame["total"] if per_frame["total"] > 0 else None,
        "torch_threads": torch.get_num_threads(),
        **details.pop("timing_notes", {}),
    }
    write_json_atomic(out / "timing.json", timing_report)
    summary = {
        "label": options.label or details["method_label"],
        "sequence": sequence.sequence,
        "data": str(Path(options.data).resolve()),
        "synthetic": sequence.is_synthetic,
        "frames": frames,
        "poses": f"{sequence.sequence}.txt",
        **details,
    }
    if sequence.has_poses:
        evaluation = evaluate(sequence.poses, trajectory)
        save_evaluation(evaluation, out / f"eval_{sequence.sequence}")
        summary["metrics"] = {k: evaluation.metrics[k] for k in ("t_err_percent", "r_err_deg_per_m", "ate_rmse_m")}
    write_json_atomic(out / "run.json", summary)
    return summary


def _run_learned(sequence: KittiSequence, options: RunOptions):
    if options.model is None:
        raise FlowvoError("the learned method needs --model CHECKPOINT (or use the packaged default via demo)")
    model, normalization, state = load_model(options.model)
    model.to(options.device)
    trained = state.get("train_config", {})
    flow_method = options.flow_method or trained.get("flow_method", "dis-medium")
    flow_scale = options.flow_scale or matching_flow_scale(sequence, state)
    estimator = create_estimator(flow_method, options.flow_weights, options.device)
    cache = FlowCache(options.flow_cache or default_cache_root(options.data), sequence, flow_method, flow_scale,
                      estimator.params())
    this_run = cache.compute(estimator)
    recorded = cache.recorded_timing() or this_run
    pairs = max(recorded["pairs"], 1)
    timing = {"image_read": recorded["read_s"] / pairs * cache.n_pairs,
              "flow": recorded["flow_s"] / pairs * cache.n_pairs}
    start = time.perf_counter()
    flows = load_network_flows(cache, model.config.input_hw, sequence.sequence)
    targets = predict_targets(model, normalization, flows, model.config.stack, options.device)
    timing["network"] = time.perf_counter() - start
    start = time.perf_counter()
    targets = temporal_median(targets, options.median_window)
    poses = chain_motions(targets, model.config.head)
    timing["chaining"] = time.perf_counter() - start
    details = {
        "method": "learned", "method_label": f"flowvo ({flow_method} + CNN)", "model": str(options.model),
        "flow_method": flow_method, "flow_scale": flow_scale, "flow_size_hw": list(cache.flow_size_hw),
        "model_config": state["model_config"], "median_window": options.median_window,
        "timing_notes": {"flow_timing": "measured when the flow cache was filled" if not this_run["pairs"]
                         else "measured in this run"},
    }
    return poses, timing, details


def matching_flow_scale(sequence: KittiSequence, state: dict) -> float:
    """Working scale that gives this sequence the flow width the model was trained on (so a model
    trained on half-resolution synthetic frames runs on full-resolution KITTI frames at scale 0.5)."""
    trained_hw = state.get("flow_size_hw")
    if trained_hw:
        return round(trained_hw[1] / sequence.image_size_hw[1], 4)
    return float(state.get("train_config", {}).get("flow_scale", 0.5))


def _run_classical(sequence: KittiSequence, options: RunOptions):
    K = sequence.calibration.K0
    steps = None
    if options.classical_scale == "gt":
        steps = planar_targets(sequence.poses.T_world_cam)[:, 0]
    read_seconds = [0.0]

    def frames():
        for index in range(len(sequence)):
            start = time.perf_counter()
            image = sequence.read_image(index)
            read_seconds[0] += time.perf_counter() - start
            yield image

    start = time.perf_counter()
    motions = classical_motions(frames(), K, steps)
    elapsed = time.perf_counter() - start
    start = time.perf_counter()
    poses = chain_se3(motions)
    chaining = time.perf_counter() - start
    timing = {"image_read": read_seconds[0], "flow": elapsed - read_seconds[0], "network": 0.0, "chaining": chaining}
    label = "classical VO (KLT + essential matrix, " + ("GT scale)" if steps is not None else "camera-height scale)")
    details = {"method": "classical", "method_label": label, "scale_source": options.classical_scale,
               "timing_notes": {"flow_stage": "KLT tracking + essential-matrix RANSAC"}}
    return poses, timing, details
