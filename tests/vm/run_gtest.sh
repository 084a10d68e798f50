#!/usr/bin/env bash
# Runs one of our GoogleTest executables inside the test VM (real SocketCAN, can-isotp, gpio-sim):
#   tests/vm/run_gtest.sh BINARY SHARED_DIR [TIMEOUT_S] [-- GTEST_ARGS...]
# The binary is built on the host and runs unchanged in the guest (the host's root filesystem is
# the guest's, see vm_run.sh), copied into SHARED_DIR first. Exit code: the test binary's
# (vm_run.sh's 97/98/99 when the VM itself failed).
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [ $# -lt 2 ]; then
  echo "usage: $0 BINARY SHARED_DIR [TIMEOUT_S] [-- GTEST_ARGS...]" >&2
  exit 2
fi
binary=$(realpath "$1") shared=$2 timeout=${3:-300}
shift 2
[ $# -gt 0 ] && [ "$1" != "--" ] && shift
[ "${1:-}" = "--" ] && shift
[ -x "$binary" ] || {
  echo "run_gtest: no executable $binary" >&2
  exit 2
}
mkdir -p "$shared" || exit 2
# The guest sees the host's root filesystem except /tmp (a fresh tmpfs there), where a build tree
# may live: the binary runs from the shared folder, which the guest always sees.
shared=$(cd "$shared" && pwd -P)
cp -f "$binary" "$shared/" || exit 2
binary=$shared/$(basename "$binary")
job=$shared/gtest-job.sh
{
  echo '#!/bin/bash'
  printf 'exec %q --gtest_color=no' "$binary"
  [ $# -gt 0 ] && printf ' %q' "$@"
  echo
} >"$job"
exec "$here/vm_run.sh" "$job" "$shared" "$timeout"
