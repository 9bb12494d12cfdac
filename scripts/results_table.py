"""Print the README's synthetic results table from the output of scripts/synthetic_kitti_results.sh.

Usage: python scripts/results_table.py OUT_DIR   (OUT_DIR holds METHOD/NN for each method below)
"""

import json
import sys
from pathlib import Path

from flowvo.report.evaluation import pooled_summary
from flowvo.report.page import load_run
from flowvo.report.reference_system import REFERENCE_FIGURES

METHODS = ("flowvo", "flowvo-geometry", "flowvo-pair", "flowvo-ba", "cnn", "classical", "classical_gt")
SEQUENCES = ("08", "09", "10")


def main(out: Path) -> None:
    runs = {(m, s): load_run(out / m / s) for m in METHODS for s in SEQUENCES}
    print("| sequence (frames) | flowvo (default), t_err % / r_err deg/m | flowvo-geometry | flowvo-pair | flowvo-ba "
          "| CNN (thesis) | classical VO, camera-height scale | classical VO, GT scale "
          "| reference system, published (real KITTI) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for s in SEQUENCES:
        cells = []
        for m in METHODS:
            metrics = runs[(m, s)].evaluation.metrics
            cells.append(f"{metrics['t_err_percent']:.2f} / {metrics['r_err_deg_per_m']:.4f}")
        ref = REFERENCE_FIGURES.get(s)
        frames = runs[("flowvo", s)].summary["frames"]
        reference = f"{ref[0]} / {ref[1]}" if ref else "not given"
        print(f"| {s} synthetic ({frames}) | " + " | ".join(cells) + f" | {reference} |")
    weighted, pooled = [], []
    for m in METHODS:
        mine = [runs[(m, s)] for s in SEQUENCES]
        frames = sum(r.summary["frames"] for r in mine)
        t = sum(r.evaluation.metrics["t_err_percent"] * r.summary["frames"] for r in mine) / frames
        r_ = sum(r.evaluation.metrics["r_err_deg_per_m"] * r.summary["frames"] for r in mine) / frames
        weighted.append(f"{t:.2f} / {r_:.4f}")
        p = pooled_summary([r.evaluation for r in mine])
        pooled.append(f"{p['t_err_percent']:.2f} / {p['r_err_deg_per_m']:.4f}")
    avg = REFERENCE_FIGURES["average 08-10"]
    print("| 08-10, frame-weighted | " + " | ".join(weighted) + f" | {avg[0]} / {avg[1]} |")
    print("| 08-10, all segments pooled | " + " | ".join(pooled) + " | |")
    print(json.dumps({"labels": {m: runs[(m, "08")].summary["label"] for m in METHODS}}))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
