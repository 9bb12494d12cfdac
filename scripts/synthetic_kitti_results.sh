#!/usr/bin/env bash
# Reproduce the README's synthetic results table: every method on the synthetic replays of KITTI 08-10,
# and one report with all of them. Usage:
#   scripts/synthetic_kitti_results.sh DATA_ROOT OUT_DIR
set -euo pipefail
data="$1"; out="$2"
runs=()
for seq in 08 09 10; do
  for method in flowvo flowvo-geometry flowvo-pair flowvo-ba cnn classical; do
    flowvo -q run --data "$data" --sequence "$seq" --method "$method" --out "$out/$method/$seq" --force
    runs+=("$out/$method/$seq")
  done
  flowvo -q run --data "$data" --sequence "$seq" --method classical --scale-from gt --out "$out/classical_gt/$seq" --force
  runs+=("$out/classical_gt/$seq")
done
flowvo report "${runs[@]}" --out "$out/report" --force
