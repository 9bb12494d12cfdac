"""Print the window stage's ablation table on the real KITTI clips: the per-pair estimate against the
scale window at several latencies and lengths, without its three-view ratios (road lengths averaged
alone), without the prior that steps leaving the window pass on, and solved by SciPy's least_squares
instead of its own iterations; the frames/s of each on clip 07 (one process, frames read in a thread
beside the rest) and the window stage's milliseconds per frame there.

Usage: python scripts/window_ablation.py [CLIPS_ROOT]
"""

import sys
from pathlib import Path

from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT, stream_clip

from flowvo.methods.cnn import load_cnn_step
from flowvo.methods.flowvo import FlowGeometryStep
from flowvo.scale_window import ScaleWindow

VARIANTS = {
    "per pair (flowvo-pair)": None,
    "window 2 s, latency 0": dict(latency_frames=0),
    "window 2 s, latency 3": dict(latency_frames=3),
    "window 2 s, latency 5 (default)": dict(latency_frames=5),
    "window 2 s, latency 10": dict(latency_frames=10),
    "window 1 s, latency 5": dict(window_s=1.0),
    "window 4 s, latency 5": dict(window_s=4.0),
    "window 2 s, latency 5, no three-view ratios": dict(ratios=False),
    "window 2 s, latency 5, steps leaving the window forgotten": dict(marginalise=False),
    "window 2 s, latency 5, SciPy's least_squares as the solver": dict(solver="scipy"),
}


def run(root: Path, clip: str, window: dict | None) -> tuple[str, str]:
    """The cell ``t_err % / path length`` of the default method with this window on ``clip``, and the cells
    frames/s and window milliseconds per frame."""
    score = stream_clip(root, clip, lambda camera, size_hw: FlowGeometryStep(
        camera, size_hw, fallback=load_cnn_step(camera, size_hw, None),
        window=None if window is None else ScaleWindow(**window)))
    return (f"{score.t_err_percent:.2f} / {100 * (score.length_ratio - 1):+.1f} %",
            f"{score.frames_per_second:.0f} | {score.window_ms:.2f}")


def main(root: Path) -> None:
    print("| variant | clip 01 (100 m) | clip 06 (10-50 m) | clip 07 (10-50 m) | frames/s (clip 07) "
          "| window ms/frame (clip 07) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name, window in VARIANTS.items():
        cells = [run(root, clip, window) for clip in CLIPS]
        print(f"| {name} | " + " | ".join(cell for cell, _ in cells) + f" | {cells[-1][1]} |", flush=True)
    print("cells: t_err % / path length against the truth; real KITTI clips, no ground truth in the method")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_CLIPS_ROOT)
