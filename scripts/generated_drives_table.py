"""Print the generated-drives table: the default method, without its network and per pair on five
generated synthetic drives with stops, slow turns and long stretches without a trusted road (600 frames
each, 620x188, sub-paths 100..400 m), per drive and pooled.

Usage: python scripts/generated_drives_table.py OUT_DIR
(renders into OUT_DIR/seed_N/data once, about a minute a drive on 2 cores; runs each method into
OUT_DIR/seed_N/METHOD/NN)
"""

import sys
from pathlib import Path

from flowvo.drive.options import RunOptions
from flowvo.drive.run import run
from flowvo.report.evaluation import pooled_summary
from flowvo.report.page import load_run
from flowvo.synth.dataset import synthesize

DRIVES = {0: ["00", "03", "22"], 1: ["02", "21"]}  # seed -> sequence names: each pair its own world and path
METHODS = ("flowvo", "flowvo-geometry", "flowvo-pair")
FRAMES = 600
LENGTHS_M = (100.0, 200.0, 300.0, 400.0)


def main(out: Path) -> None:
    evaluations: dict[str, list] = {method: [] for method in METHODS}
    print("| drive | " + " | ".join(METHODS) + " |")
    print("| --- | " + " | ".join("---" for _ in METHODS) + " |")
    for seed, names in DRIVES.items():
        data = out / f"seed_{seed}" / "data"
        synthesize(data, names, seed=seed, frames=FRAMES, scale=0.5)  # reuses frames rendered before
        for name in names:
            cells = []
            for method in METHODS:
                target = out / f"seed_{seed}" / method / name
                run(RunOptions(out=str(target), data=str(data), sequence=name, method=method, lengths_m=LENGTHS_M,
                               force=True))
                evaluation = load_run(target).evaluation
                evaluations[method].append(evaluation)
                cells.append(f"{evaluation.metrics['t_err_percent']:.2f} / {evaluation.metrics['r_err_deg_per_m']:.4f}")
            print(f"| seed {seed}, {name} | " + " | ".join(cells) + " |", flush=True)
    pooled = [pooled_summary(evaluations[method]) for method in METHODS]
    print("| pooled | " + " | ".join(f"{p['t_err_percent']:.2f} / {p['r_err_deg_per_m']:.4f}" for p in pooled) + " |")
    print("cells: t_err % / r_err deg/m on 100..400 m sub-paths; synthetic drives, not real KITTI")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
