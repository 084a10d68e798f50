#!/usr/bin/env bash
# Runs a command with another beside it at idle priority (SCHED_IDLE: it gets only the CPU the
# first leaves unused), then waits for the second; `make test` builds the aarch64 cross build
# beside the release suite, whose emulated guests leave part of the two cores idle.
#   tests/beside.sh LOG 'BACKGROUND COMMAND' FOREGROUND COMMAND...
# The background command's output goes to LOG (its tail is printed if it fails). Exit status: the
# foreground command's if it failed, else the background command's.
set -uo pipefail
if [[ $# -lt 3 ]]; then
  echo "usage: $0 LOG 'BACKGROUND COMMAND' FOREGROUND COMMAND..." >&2
  exit 2
fi
log=$1 background=$2
shift 2
mkdir -p "$(dirname "$log")"
chrt --idle 0 bash -c "$background" >"$log" 2>&1 &
pid=$!
"$@"
status=$?
echo "beside: waiting for '$background' (log: $log)"
wait "$pid"
background_status=$?
if [[ $background_status != 0 ]]; then
  echo "beside: '$background' failed ($background_status); the end of $log:" >&2
  tail -n 40 "$log" >&2
fi
[[ $status != 0 ]] && exit "$status"
exit "$background_status"
