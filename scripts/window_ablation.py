"""Print the window stage's ablation table on the real KITTI clips: the per-pair estimate against the
scale window at several latencies and lengths, without its three-view ratios (road lengths averaged
alone), without the prior that steps leaving the window pass on, and solved by SciPy's least_squares
instead of its own iterations; then the bundle stage behind it (``flowvo-ba``) over 6, 10 and 15 frames,
with the bundle's own rotations, solved every second frame, and under Huber's loss or none; the frames/s of
each on clip 07 (one process, frames read in a thread beside the rest) and the window stage's milliseconds per
frame there (the bundle stage's included).

Usage: python scripts/window_ablation.py [CLIPS_ROOT]
"""

import sys
from pathlib import Path

from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT, stream_clip

from flowvo.methods.cnn import load_cnn_step
from flowvo.methods.flowvo import FlowGeometryStep
from flowvo.odometry.bundle_window import BundleSettings
from flowvo.odometry.scale_window import ScaleWindow
from flowvo.odometry.scale_window_scipy import scipy_log_lengths

DEFAULT_WINDOW: dict = {}
VARIANTS: dict[str, tuple[dict | None, BundleSettings | None]] = {
    "per pair (flowvo-pair)": (None, None),
    "window 2 s, latency 0": (dict(latency_frames=0), None),
    "window 2 s, latency 3": (dict(latency_frames=3), None),
    "window 2 s, latency 5 (default)": (DEFAULT_WINDOW, None),
    "window 2 s, latency 10": (dict(latency_frames=10), None),
    "window 1 s, latency 5": (dict(window_s=1.0), None),
    "window 4 s, latency 5": (dict(window_s=4.0), None),
    "window 2 s, latency 5, no three-view ratios": (dict(ratios=False), None),
    "window 2 s, latency 5, steps leaving the window forgotten": (dict(marginalise=False), None),
    "window 2 s, latency 5, SciPy's least_squares as the solver": (dict(solver=scipy_log_lengths), None),
    "default + bundle adjustment over 6 frames": (DEFAULT_WINDOW, BundleSettings(frames=6)),
    "default + bundle adjustment over 10 frames (flowvo-ba)": (DEFAULT_WINDOW, BundleSettings()),
    "default + bundle adjustment over 10 frames, its own rotations": (DEFAULT_WINDOW,
                                                                      BundleSettings(own_rotations=True)),
    "default + bundle adjustment over 15 frames": (DEFAULT_WINDOW, BundleSettings(frames=15)),
    "default + bundle adjustment over 10 frames, solved every 2nd": (DEFAULT_WINDOW, BundleSettings(every=2)),
    "default + bundle adjustment over 10 frames, Huber's loss": (DEFAULT_WINDOW, BundleSettings(loss="huber")),
    "default + bundle adjustment over 10 frames, no robust loss": (DEFAULT_WINDOW, BundleSettings(loss="none")),
}


def run(root: Path, clip: str, window: dict | None, bundle: BundleSettings | None) -> tuple[str, str]:
    """The cell ``t_err % / r_err deg/m / path length`` of the default method with this window and bundle stage on
    ``clip``, and the cells frames/s and window milliseconds per frame."""
    score = stream_clip(root, clip, lambda camera, size_hw: FlowGeometryStep(
        camera, size_hw, fallback=load_cnn_step(camera, size_hw, None),
        window=None if window is None else ScaleWindow(**window), bundle=bundle))
    return (f"{score.t_err_percent:.2f} / {score.r_err_deg_per_m:.4f} / {100 * (score.length_ratio - 1):+.1f} %",
            f"{score.frames_per_second:.0f} | {score.window_ms:.2f}")


def main(root: Path) -> None:
    print("| variant | clip 01 (100 m) | clip 06 (10-50 m) | clip 07 (10-50 m) | frames/s (clip 07) "
          "| window ms/frame (clip 07) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name, (window, bundle) in VARIANTS.items():
        cells = [run(root, clip, window, bundle) for clip in CLIPS]
        print(f"| {name} | " + " | ".join(cell for cell, _ in cells) + f" | {cells[-1][1]} |", flush=True)
    print("cells: t_err % / r_err deg/m / path length against the truth; real KITTI clips, no ground truth in the "
          "method")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_CLIPS_ROOT)
