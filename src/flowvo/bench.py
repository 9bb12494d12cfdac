"""``flowvo bench``: streaming per-frame timing of each stage, repeated runs, medians.

Unlike ``flowvo run`` (batched network, cached flow), this processes frames one at a time as a car's
computer would: read, flow, network on one sample, chaining. Seconds per frame are means over the
frames of a run; the table shows the median over runs.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import torch

from flowvo.classical_vo import classical_motions
from flowvo.flow.cache import resize_frame
from flowvo.flow.registry import create_estimator
from flowvo.geometry import chain_planar, chain_se3, se3_from_targets
from flowvo.kitti.sequence import KittiSequence
from flowvo.model.checkpoint import load_model
from flowvo.model.data import resize_flow
from flowvo.model.inference import predict_batch
from flowvo.pipeline import matching_flow_scale
from flowvo.report import stage_seconds_text

STAGES = ("image_read", "flow", "network", "chaining")


def _time_learned(sequence: KittiSequence, frames: int, model_path: Path, flow_method: str | None) -> dict:
    model, normalization, state = load_model(model_path)
    method = flow_method or state["train_config"]["flow_method"]
    scale = matching_flow_scale(sequence, state)
    estimator = create_estimator(method)
    seconds = dict.fromkeys(STAGES, 0.0)
    pose = np.eye(4)
    previous = resize_frame(sequence.read_image(0), scale)
    cx_px = float(sequence.calibration.K0[0, 2]) * previous.shape[1] / sequence.image_size_hw[1]
    with torch.no_grad():
        for index in range(1, frames):
            t0 = time.perf_counter()
            current = resize_frame(sequence.read_image(index), scale)
            t1 = time.perf_counter()
            flow = estimator.estimate(previous, current)
            t2 = time.perf_counter()
            channels = torch.from_numpy(resize_flow(flow, model.config.input_hw, cx_px))[None]
            channels = channels / normalization.flow_std_px
            if model.config.stack > 1:
                channels = channels.repeat(1, model.config.stack, 1, 1)
            motion = predict_batch(model, normalization, channels)
            t3 = time.perf_counter()
            if model.config.head == "planar":
                pose = chain_planar(motion, pose)[-1]
            else:
                pose = chain_se3(se3_from_targets(motion), pose)[-1]
            t4 = time.perf_counter()
            for stage, seconds_taken in zip(STAGES, (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True):
                seconds[stage] += seconds_taken
            previous = current
    return {"label": f"flowvo ({method} + CNN)", **{k: v / (frames - 1) for k, v in seconds.items()}}


def _time_classical(sequence: KittiSequence, frames: int) -> dict:
    read = [0.0]

    def images():
        for index in range(frames):
            start = time.perf_counter()
            image = sequence.read_image(index)
            read[0] += time.perf_counter() - start
            yield image

    start = time.perf_counter()
    motions = classical_motions(images(), sequence.calibration.K0, None)
    total = time.perf_counter() - start
    start = time.perf_counter()
    chain_se3(motions)
    chaining = time.perf_counter() - start
    n = frames - 1
    return {"label": "classical VO (KLT + essential matrix)", "image_read": read[0] / n,
            "flow": (total - read[0]) / n, "network": 0.0, "chaining": chaining / n}


def benchmark(data: str | Path, sequence_name: str, methods: list[str], frames: int, repeat: int,
              model: str | Path | None, flow_method: str | None = None) -> list[dict]:
    """Median seconds per frame by stage for each method ("learned", "classical")."""
    sequence = KittiSequence(data, sequence_name)
    sequence.require_frames(2, "timing")
    frames = min(frames, len(sequence))
    rows = []
    for method in methods:
        runs = []
        for _ in range(repeat):
            if method == "learned":
                from flowvo.demo import packaged_model_path

                runs.append(_time_learned(sequence, frames, Path(model) if model else packaged_model_path(),
                                          flow_method))
            else:
                runs.append(_time_classical(sequence, frames))
        row = {"label": runs[0]["label"], "method": method, "frames": frames, "repeats": repeat}
        for stage in STAGES:
            row[stage] = float(np.median([r[stage] for r in runs]))
        row["total"] = float(np.median([sum(r[s] for s in STAGES) for r in runs]))
        rows.append(row)
    return rows


def format_bench_table(rows: list[dict], reference_seconds: float = 0.633) -> str:
    """The timing table, as in the reference study, with speed-ups."""
    names = ("read", "flow", "network", "chain", "total")
    header = f"{'method':40s} " + " ".join(f"{n:>8s}" for n in names) + f" {'fps':>7s} {'vs ref':>7s}"
    lines = [header, "-" * len(header)]
    for row in rows:
        network = stage_seconds_text(row["method"], "network", row["network"])
        lines.append(f"{row['label']:40s} {row['image_read']:8.4f} {row['flow']:8.4f} {network:>8s} "
                     f"{row['chaining']:8.5f} {row['total']:8.4f} {1 / row['total']:7.1f} "
                     f"{reference_seconds / row['total']:6.1f}x")
    lines.append(f"{'reference system (2016), published, GPU':40s} {'':8s} {'':8s} {'':8s} {'':8s} "
                 f"{reference_seconds:8.3f} {1 / reference_seconds:7.1f} {'1.0x':>7s}")
    lines.append("seconds per frame, median of repeated streaming runs; torch threads: "
                 f"{torch.get_num_threads()}")
    return "\n".join(lines)
