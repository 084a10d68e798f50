#!/usr/bin/env bash
# Runs a job in the test VM with the real agent and the agent_diag_vmtest drive at hand:
#   tests/vm/agent_job.sh BUILD_DIR JOB SHARED_DIR TIMEOUT_S [FILE...]
# BUILD_DIR: a release build, whose tests/tmp/agent_diag_vmtest the build fills (calibd-agent,
# calibd-sim, calibd-tester; session.lcmlog: 100 pairs at 5 Hz, m1, 960x480 JPEG; calib.yaml).
# Those and each FILE are copied into SHARED_DIR, the job's working directory in the guest;
# copies, not links, so that a rebuild while the VM runs does not change the programs under it.
# Exit code: vm_run.sh's (the job's, or 97/98/99 for the VM); 2 when a file is missing.
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [ $# -lt 4 ]; then
  echo "usage: $0 BUILD_DIR JOB SHARED_DIR TIMEOUT_S [FILE...]" >&2
  exit 2
fi
build=$1 job=$2 shared=$3 timeout=$4
shift 4
data=$build/tests/tmp/agent_diag_vmtest
mkdir -p "$shared" || exit 2
for f in "$data/calibd-agent" "$data/calibd-sim" "$data/calibd-tester" "$data/session.lcmlog" \
  "$data/calib.yaml" "$@"; do
  [ -e "$f" ] || {
    echo "$(basename "$0"): missing $f (build the release preset first)" >&2
    exit 2
  }
  cp -f "$f" "$shared/" || exit 2
done
exec "$here/vm_run.sh" "$job" "$shared" "$timeout"
