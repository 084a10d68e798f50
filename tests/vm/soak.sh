#!/usr/bin/env bash
# The soak in the test VM: calibd-bench soak for MINUTES on the guest's vcan0 (UDS on
# the kernel's can-isotp) and its loopback multicast (LCM udpm), on the drive agent_diag_vmtest
# uses (100 pairs at 5 Hz, m1, 960x480 JPEG), replayed at a fifth of real time for the emulated guest.
#   tests/vm/soak.sh BUILD_DIR MINUTES [SHARED_DIR]
# BUILD_DIR: a release build. SHARED_DIR (default BUILD_DIR/tests/tmp/soak) receives the
# programs (tests/vm/agent_job.sh), the job, the console log, soak.txt (the table and checks),
# soak-progress.txt and soak.json (every sample). Exit code: calibd-bench's (1: a check
# failed), or vm_run.sh's 97/98/99.
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [ $# -lt 2 ]; then
  echo "usage: $0 BUILD_DIR MINUTES [SHARED_DIR]" >&2
  exit 2
fi
build=$(cd "$1" && pwd) minutes=$2 shared=${3:-$1/tests/tmp/soak}
mkdir -p "$shared" || exit 2
shared=$(cd "$shared" && pwd -P)
rm -f "$shared/soak.txt" "$shared/soak.json" "$shared/soak-progress.txt"
job=$shared/soak-job.sh
# --max-translation-bound-m, --max-rotation-bound-deg: 60 pairs of small tags bound their result
# beyond the default 0.3 deg / 3 cm (kShortSessionRotationBoundDeg, kShortSessionTranslationBoundM,
# tests/short_session.hpp).
cat >"$job" <<JOB
#!/bin/bash
# LCM udpm on the guest's loopback, with receive buffers for whole sweeps (as agent_diag_vmtest).
ip link set lo multicast on && ip route replace 224.0.0.0/4 dev lo &&
  sysctl -q -w net.core.rmem_max=33554432 net.core.rmem_default=4194304 || exit 3
cd "$shared" || exit 3
./calibd-bench soak --minutes $minutes --agent ./calibd-agent --sim ./calibd-sim \\
  --drive session.lcmlog --calib-yaml calib.yaml --interface vcan0 --speed 0.2 --min-distance-bins 1 \\
  --max-translation-bound-m 0.1 --max-rotation-bound-deg 0.6 \\
  --work-dir /tmp/soak --json soak.json >soak.txt 2>soak-progress.txt
code=\$?
cp /tmp/soak/agent.log soak-agent.log 2>/dev/null
exit \$code
JOB
# The VM's own time limit: the soak, the session running when it ends (up to the agent's
# 150 s limit), the agent's start in the guest and the boot.
timeout=$(awk -v m="$minutes" 'BEGIN { printf "%d", m * 60 + 420 }')
"$here/agent_job.sh" "$build" "$job" "$shared" "$timeout" "$build/tools/bench/calibd-bench"
code=$?
cat "$shared/soak-progress.txt" "$shared/soak.txt" 2>/dev/null
exit "$code"
