"""What a millisecond costs the stream in each of its threads: the default method on real clip 07, as it is and
with one millisecond added to every step in the reader thread (after ``prepare``) or the motion thread (after
``motion``), busy in Python (holding the GIL and a core) or asleep (holding neither). The cases take turns, round
after round.

A stream whose two threads overlapped perfectly would lose 0.5 ms a frame to a busy millisecond on either side and
nothing to a sleep in the thread with slack. Run: ``python benchmarks/bench_stream_slack.py [--rounds 5]``.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from _table import print_table

import flowvo
from flowvo.methods.flowvo import FlowGeometryStep

CLIPS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real" / "kitti_clips"
FRAMES = 160
CASES = (("as it is", None, None), ("reader, busy", "prepare", "busy"), ("reader, asleep", "prepare", "asleep"),
         ("motion, busy", "motion", "busy"), ("motion, asleep", "motion", "asleep"))


def added_millisecond(method, kind: str):
    """``method`` followed by one millisecond, spent busy in Python or asleep."""
    def wrapped(*args, **kwargs):
        result = method(*args, **kwargs)
        if kind == "asleep":
            time.sleep(1e-3)
        else:
            end = time.perf_counter() + 1e-3
            while time.perf_counter() < end:
                pass
        return result
    return wrapped


def stream_ms_per_frame() -> float:
    """The wall clock of one whole stream of the clip, ms a frame."""
    start = time.perf_counter()
    flowvo.run(str(CLIPS), sequence="07", max_frames=FRAMES)
    return (time.perf_counter() - start) / FRAMES * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5, help="rounds, each streaming every case once in turn")
    args = parser.parse_args()
    if not CLIPS.is_dir():
        raise SystemExit(f"real KITTI clips not found at {CLIPS}")
    flowvo.run(str(CLIPS), sequence="07", max_frames=10)  # imports and caches warm
    walls: dict[str, list[float]] = {label: [] for label, _, _ in CASES}
    for _ in range(args.rounds):  # the cases in turn, so that a machine whose speed drifts weighs on all alike
        for label, stage, kind in CASES:
            original = getattr(FlowGeometryStep, stage) if stage else None
            if stage:
                setattr(FlowGeometryStep, stage, added_millisecond(original, kind))
            try:
                walls[label].append(stream_ms_per_frame())
            finally:
                if stage:
                    setattr(FlowGeometryStep, stage, original)
    baseline = statistics.median(walls[CASES[0][0]])
    rows = [[label, round(statistics.median(values), 2), round(statistics.median(values) - baseline, 2)]
            for label, values in walls.items()]
    print_table(f"default method, real clip 07, {FRAMES} frames, medians of {args.rounds} rounds",
                ["one millisecond added", "wall ms a frame", "cost, ms a frame"], rows)


if __name__ == "__main__":
    main()
