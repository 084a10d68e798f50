#!/usr/bin/env bash
# Instruction counts of each calibration stage, for regressions a noisy machine would hide
# (callgrind counts instructions, not time: the same binary and inputs give the same counts).
# Runs `calibd-bench pipeline` (no agent) under callgrind on a short drive and prints each stage's
# inclusive instruction count (Ir) per call. Counts are of the calling thread: work on AprilTag's
# and Ceres' worker threads is not included (set by CameraDetectorConfig/DirectOptimizerConfig
# threads), so compare counts of one build configuration with each other only.
#
# Usage: tools/bench/instruction_counts.sh [BUILD_DIR] [LIDAR] [FRAMES]
#   defaults: build/release ot128 10. About 5 min on 2 cores.
set -euo pipefail
build=${1:-build/release}
lidar=${2:-ot128}
frames=${3:-10}
bench="$build/tools/bench/calibd-bench"
[ -x "$bench" ] || { echo "instruction_counts: $bench not built" >&2; exit 1; }
command -v valgrind >/dev/null || { echo "instruction_counts: valgrind not installed" >&2; exit 1; }
out=$(mktemp -d)
[ -n "${KEEP:-}" ] || trap 'rm -rf "$out"' EXIT
valgrind --tool=callgrind --compress-strings=no --compress-pos=no --callgrind-out-file="$out/cg" \
  "$bench" pipeline --lidar "$lidar" --frames "$frames" --agent none --engine-runs 1 >"$out/bench.txt" 2>"$out/vg.txt" || {
  echo "instruction_counts: the bench failed under callgrind:" >&2
  tail -20 "$out/vg.txt" >&2
  exit 1
}
callgrind_annotate --inclusive=yes --threshold=100 "$out/cg" >"$out/annotate.txt"
printf '%s, %s frame pairs (calibd-bench pipeline --agent none under callgrind)\n\n' "$lidar" "$frames"
printf '| stage | function | Ir inclusive | per |\n|---|---|---|---|\n'
# The pipeline calls each detector once per frame pair and the engine three times (the default,
# paper Eq. 4 alone, the indirect method): grid search 3 times, OptimizeDirect 3 times (the
# indirect run evaluates its result with it), OptimizeIndirect once.
for row in "LiDAR detection|calibd::LidarDetector::Detect(|$frames|frame pair" \
           "camera detection (calling thread)|calibd::CameraDetector::Detect(|$frames|frame pair" \
           "grid search|calibd::GridSearch::Run(|3|engine run" \
           "direct optimisation (calling thread)|calibd::OptimizeDirect(|3|call" \
           "indirect optimisation (calling thread)|calibd::OptimizeIndirect(|1|call" \
           "whole engine (calling thread)|calibd::Calibrate(|3|engine run"; do
  IFS='|' read -r stage fn n per <<<"$row"
  ir=$(grep -F ":$fn" "$out/annotate.txt" | head -1 | awk '{gsub(",","",$1); print $1}' || true)
  if [ -z "$ir" ]; then
    printf '| %s | `%s...)` | not reached | |\n' "$stage" "$fn"
  else
    printf '| %s | `%s...)` | %s | %s per %s |\n' "$stage" "$fn" "$ir" "$((ir / n))" "$per"
  fi
done
