#!/usr/bin/env bash
# The main job, run by `make demo`: a simulated workshop session end to end. Simulate the default
# session (OT128-like LiDAR, 3 boards, 200 frame pairs driving 6-30 m, prior off by 5 deg and 5 cm),
# calibrate it from the log and the config alone, and compare with the simulator's truth; then
# replay the same log through the on-vehicle agent, which calibrates on its own and commits the
# result to its calibration store.
set -euo pipefail
build=${1:-build/release}
out=${CALIBD_DEMO_DIR:-out/demo}
mkdir -p "$out"
echo "== 1/3 simulating a workshop session into $out/ (about 45 s)"
"$build/tools/sim/calibd-sim" --seed 1 --lidar ot128 --prior-rot-deg 5 --prior-trans-m 0.05 \
  --out "$out/session.lcmlog" --truth "$out/truth.json" --config-out "$out/calib.yaml" \
  --overlay-png "$out/frame.png" --overlay-frame 0
echo
echo "== 2/3 calibrating from the log and the config (the truth is only used to score the result)"
status=0
"$build/tools/calibrate/calibd-calibrate" --log "$out/session.lcmlog" --config "$out/calib.yaml" \
  --report "$out/report.json" --overlay "$out/overlay" --html "$out/report.html" \
  --truth "$out/truth.json" || status=$?
echo
echo "== 3/3 the agent: calibd-agent replays the log as live frames (--calibrate-now), auto-commit on"
rm -rf "$out/store"
cp "$out/calib.yaml" "$out/agent.yaml"
printf 'agent:\n  auto_commit: true\n  store:\n    directory: %s\n' "$(realpath "$out")/store" \
  >> "$out/agent.yaml"
agent_status=0
"$build/agent/calibd-agent" --config "$out/agent.yaml" --calibrate-now --once \
  --lcm-url "file://$(realpath "$out/session.lcmlog")?speed=0" \
  --publish-url "file://$(realpath "$out")/agent-out.lcmlog?mode=w" || agent_status=$?
echo "agent exit code $agent_status; stored calibration: $out/store/current.json"
echo
echo "== report: $out/report.json (for people: $out/report.html)   pictures: $out/overlay/"
echo "   config: $out/calib.yaml"
echo "   agent: $out/agent.yaml, store $out/store/, published messages $out/agent-out.lcmlog"
[ "$status" -eq 0 ] || exit $status
exit $agent_status
