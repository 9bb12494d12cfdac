"""Per-frame speed: the packaged network alone (PyTorch and ONNX Runtime), then every method streaming
the real clip 07 (../shared/data/real/kitti_clips, 1226x370) frame by frame as ``flowvo bench`` does
(a rendered 150-frame synthetic drive when the clips are absent); medians of 3 runs.
Run: python benchmarks/bench_inference.py
"""

import tempfile
import time
from pathlib import Path

import numpy as np
import torch
from _table import print_table

from flowvo.drive.bench import benchmark, format_bench_table
from flowvo.drive.options import RunOptions
from flowvo.model.checkpoint import load_model, packaged_model_path
from flowvo.model.export import export_onnx
from flowvo.model.network import flops_per_frame, parameter_count
from flowvo.model.onnx_runtime import OnnxOdometry
from flowvo.synth.dataset import synthesize


def network_alone() -> None:
    model, _, _ = load_model(packaged_model_path())
    rows = []
    for batch in (1, 64):
        x = torch.zeros(batch, 2 * model.config.stack, *model.config.input_hw)
        with torch.no_grad():
            model(x)
            times = []
            for _ in range(10 if batch == 1 else 3):
                start = time.perf_counter()
                model(x)
                times.append((time.perf_counter() - start) / batch)
        rows.append([f"{model.config.input_hw[1]}x{model.config.input_hw[0]}", batch, float(np.median(times))])
    print_table(
        f"network alone: width {model.config.width}, {parameter_count(model) / 1e6:.2f} M parameters, "
        f"{flops_per_frame(model) / 1e9:.3f} GFLOP per frame, {torch.get_num_threads()} threads",
        ["input", "batch", "s_per_frame"], rows,
    )


def onnx_against_torch() -> None:
    """Batch-1 symmetric inference (the streaming case): PyTorch module against ONNX Runtime, one thread."""
    from flowvo.model.deployable import DeployableOdometry

    module = DeployableOdometry.from_checkpoint(packaged_model_path())
    flow = np.random.default_rng(0).normal(0, 3, (1, 2 * module.stack, *module.input_hw)).astype(np.float32)
    with tempfile.TemporaryDirectory() as folder:
        export_onnx(packaged_model_path(), Path(folder) / "m.onnx")
        runtime = OnnxOdometry(Path(folder) / "m.onnx")
        rows = []
        for name, predict in (("pytorch", module.predict), ("onnxruntime", runtime.predict)):
            predict(flow)
            start = time.perf_counter()
            for _ in range(200):
                predict(flow)
            rows.append([name, (time.perf_counter() - start) / 200])
    print_table(f"network with mirrored pass, batch 1, torch threads {torch.get_num_threads()}",
                ["runtime", "s_per_frame"], rows)


def main() -> None:
    network_alone()
    onnx_against_torch()
    clips = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real" / "kitti_clips"
    methods = ["flowvo", "flowvo-geometry", "cnn", "classical"]
    if (clips / "sequences" / "07").is_dir():
        rows = benchmark(RunOptions(out="", data=str(clips), sequence="07"), methods, frames=160, repeat=3)
        print("\nstreaming, real KITTI clip 07 (1226x370, 160 frames):")
    else:
        with tempfile.TemporaryDirectory() as root:
            synthesize(root, ["00"], seed=77, frames=150, scale=1.0)
            rows = benchmark(RunOptions(out="", data=root, sequence="00"), methods, frames=150, repeat=3)
        print("\nstreaming, 1241x376 synthetic frames (real clips not found):")
    print(format_bench_table(rows))


if __name__ == "__main__":
    main()
