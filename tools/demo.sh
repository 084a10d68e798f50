#!/usr/bin/env bash
# The main job, run by `make demo`: simulate a default workshop session (ot128, 3 boards, 200 frame
# pairs, prior off by 5 deg and 5 cm) and show what was made. Later issues make it calibrate.
set -euo pipefail
build=${1:-build/release}
out=${CALIBD_DEMO_DIR:-out/demo}
mkdir -p "$out"
echo "== calibd demo: simulating a workshop session into $out/"
"$build/tools/sim/calibd-sim" --seed 1 --lidar ot128 \
  --out "$out/session.lcmlog" --truth "$out/truth.json" --config-out "$out/calib.yaml" \
  --overlay-png "$out/frame.png" --overlay-frame 0
echo "== calibration config a user would write for this vehicle: $out/calib.yaml"
echo "== picture of frame 0 with the LiDAR points projected: $out/frame.png"
