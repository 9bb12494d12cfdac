"""Flow methods on synthetic sequences with true flow: end-point error and seconds per frame pair.

EPE is over pixels visible in both frames; "road" = ground within 25 m, "distant" = beyond 60 m or sky.
FlowNetS is timed with random weights (no weights ship with flowvo), so its EPE is not reported.
Run: python benchmarks/bench_flow.py [--frames 8]
"""

import argparse
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import torch
from _table import print_table

from flowvo.flow.flownets import FlowNetS, FlowNetSFlow
from flowvo.flow.registry import create_estimator
from flowvo.kitti.sequence import KittiSequence
from flowvo.synth.dataset import synthesize
from flowvo.synth.world import SCENE_TYPES

CLASSICAL = ("dis-ultrafast", "dis-fast", "dis-medium", "farneback")


def evaluate(method_name: str, estimator, sequences: list[KittiSequence]) -> list:
    errors = {"all": [], "road": [], "distant": []}
    seconds = []
    for sequence in sequences:
        flow_dir = sequence.directory / "flow_gt"
        for index in range(len(sequence) - 1):
            prev, following = sequence.read_image(index), sequence.read_image(index + 1)
            start = time.perf_counter()
            flow = estimator.estimate(prev, following)
            seconds.append(time.perf_counter() - start)
            truth = np.load(flow_dir / f"{index:06d}.npy")
            visible = cv2.imread(str(flow_dir / f"{index:06d}_occluded.png"), 0) == 0
            depth = np.load(flow_dir / f"{index:06d}_depth.npy").astype(np.float32)
            epe = np.linalg.norm(flow - truth, axis=-1)
            rows = np.arange(depth.shape[0])[:, None] > depth.shape[0] * 0.55
            errors["all"].append(epe[visible])
            errors["road"].append(epe[visible & rows & (depth < 25)])
            errors["distant"].append(epe[visible & ~(depth < 60)])
    means = [float(np.concatenate(errors[k]).mean()) for k in ("all", "road", "distant")]
    return [method_name, *means, float(np.median(seconds))]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=8)
    args = parser.parse_args()
    torch.set_num_threads(2)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scale in (1.0, 0.5):
            sequences = []
            for k, scene in enumerate(SCENE_TYPES):
                root = Path(tmp) / f"{scene}_{scale}"
                synthesize(root, ["00"], seed=40 + k, frames=args.frames, scale=scale, scene=scene, gt_flow=True)
                sequences.append(KittiSequence(root, "00"))
            size = "x".join(map(str, sequences[0].image_size_hw[::-1]))
            for method in CLASSICAL:
                rows.append([size, *evaluate(method, create_estimator(method), sequences)])
            flownets = FlowNetSFlow.__new__(FlowNetSFlow)
            flownets.model, flownets.device = FlowNetS().eval(), "cpu"
            image = sequences[0].read_image(0)
            flownets.estimate(image, image)
            start = time.perf_counter()
            for _ in range(2):
                flownets.estimate(image, image)
            rows.append([size, "flownets (random weights)", "-", "-", "-", (time.perf_counter() - start) / 2])
    print_table(
        "flow on synthetic sequences (urban, suburban, open), 2 CPU cores",
        ["size", "method", "EPE_all_px", "EPE_road_px", "EPE_distant_px", "s_per_pair"],
        rows,
    )


if __name__ == "__main__":
    main()
