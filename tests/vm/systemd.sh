#!/usr/bin/env bash
# calibd.service under systemd in the test VM: tests/vm/systemd-job.sh, with the guest
# booted by the host's systemd (CALIBD_VM_INIT=systemd, see guest-init.sh).
#   tests/vm/systemd.sh BUILD_DIR [SHARED_DIR]
# BUILD_DIR: a release build; SHARED_DIR defaults to BUILD_DIR/tests/tmp/systemd. Exit code: the
# job's (the number of failed checks), or vm_run.sh's 97/98/99.
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
if [ $# -lt 1 ]; then
  echo "usage: $0 BUILD_DIR [SHARED_DIR]" >&2
  exit 2
fi
build=$(cd "$1" && pwd) shared=${2:-$1/tests/tmp/systemd}
CALIBD_VM_INIT=systemd exec "$here/agent_job.sh" "$build" "$here/systemd-job.sh" "$shared" 600 \
  "$repo/deploy/systemd/calibd.service.in" "$repo/deploy/systemd/calibd.sysusers"
