#!/usr/bin/env bash
# Reproduce the README's synthetic results table: the learned model and the classical baseline on the
# synthetic replays of KITTI 08-10, and one report with both. Usage:
#   scripts/synthetic_kitti_results.sh DATA_ROOT MODEL.pt OUT_DIR
set -euo pipefail
data="$1"; model="$2"; out="$3"
runs=()
for seq in 08 09 10; do
  flowvo run --data "$data" --sequence "$seq" --model "$model" --out "$out/learned/$seq" -q
  runs+=("$out/learned/$seq")
  for scale in gt height; do
    [ -f "$out/classical_$scale/$seq/run.json" ] || \
      flowvo run --data "$data" --sequence "$seq" --method classical --scale-from "$scale" \
        --out "$out/classical_$scale/$seq" -q
    runs+=("$out/classical_$scale/$seq")
  done
done
flowvo report "${runs[@]}" --out "$out/report"
