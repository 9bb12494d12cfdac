"""Per-frame inference speed of the packaged model, flow included, against the classical baseline.

Renders a 150-frame synthetic drive at half KITTI resolution (620x188), then streams it frame by frame:
read, flow, network (one sample), chaining; median of 3 runs. Also times the network alone at the default
input size for batch 1 and 64.
Run: python benchmarks/bench_inference.py
"""

import tempfile
import time

import numpy as np
import torch
from _table import print_table

from flowvo.bench import benchmark, format_bench_table
from flowvo.demo import packaged_model_path
from flowvo.model.checkpoint import load_model
from flowvo.model.network import flops_per_frame, parameter_count
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


def main() -> None:
    network_alone()
    with tempfile.TemporaryDirectory() as root:
        synthesize(root, ["00"], seed=77, frames=150, scale=0.5)
        rows = benchmark(root, "00", ["learned", "classical"], frames=150, repeat=3, model=None)
    print("\nstreaming, 620x188 synthetic frames (KITTI at half resolution):")
    print(format_bench_table(rows))


if __name__ == "__main__":
    main()
