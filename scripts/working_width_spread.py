"""How much the default method's accuracy on the real clips depends on the working width: t_err of each clip
at working widths 600..640 px in steps of 4, and each clip's worst t_err over its best.

Usage: python scripts/working_width_spread.py [CLIPS_ROOT] [--per-pair]   (--per-pair: flowvo-pair's estimate)
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

from clip_runs import CLIPS, DEFAULT_CLIPS_ROOT, stream_clip

from flowvo.methods.flowvo import FlowGeometryStep
from flowvo.odometry.scale_window import ScaleWindow

WIDTHS_PX = tuple(range(600, 641, 4))


def t_err_percent(clips: str, clip: str, width_px: int, per_pair: bool) -> float:
    """flowvo-geometry's t_err on ``clip`` at working width ``width_px`` (the network fallback is trained at
    620 px only); ``per_pair``: without the scale window."""
    return stream_clip(Path(clips), clip, lambda camera, size_hw: FlowGeometryStep(
        camera, size_hw, working_width=width_px, window=None if per_pair else ScaleWindow())).t_err_percent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clips", nargs="?", default=str(DEFAULT_CLIPS_ROOT))
    parser.add_argument("--per-pair", action="store_true", help="the per-pair estimate (no scale window)")
    args = parser.parse_args()
    print("| clip | " + " | ".join(f"{w} px" for w in WIDTHS_PX) + " | median | worst / best |")
    print("| --- |" + " --- |" * (len(WIDTHS_PX) + 2))
    for clip in CLIPS:
        errors = [t_err_percent(args.clips, clip, width, args.per_pair) for width in WIDTHS_PX]
        print(f"| {clip} | " + " | ".join(f"{e:.2f}" for e in errors)
              + f" | {statistics.median(errors):.2f} | {max(errors) / min(errors):.2f}x |")
    print(f"t_err % of flowvo-geometry{' per pair' if args.per_pair else ''} (the network fallback is trained at "
          "620 px only); 01: 100 m sub-paths, 06/07: 10-50 m")


if __name__ == "__main__":
    main()
