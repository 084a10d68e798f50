#!/usr/bin/env bash
# `make test`'s phase clock: runs one phase's command, appends its wall time to the table in
# $CALIBD_PHASES (one "seconds<TAB>name<TAB>status" line per phase), and exits with the command's
# status. `timed_phase.sh --print` prints the table with its total.
set -uo pipefail
table=${CALIBD_PHASES:-build/phase-times.tsv}
if [[ ${1:-} == --print ]]; then
  [[ -f $table ]] || exit 0
  awk -F'\t' '{ printf "  %-34s %6d s  %s\n", $2, $1, $3; total += $1 }
              END { printf "  %-34s %6d s (%.1f min)\n", "total", total, total / 60 }' "$table"
  exit 0
fi
name=$1
shift
mkdir -p "$(dirname "$table")"
start=$(date +%s)
"$@"
status=$?
echo -e "$(($(date +%s) - start))\t$name\t$([[ $status == 0 ]] && echo ok || echo "failed ($status)")" >> "$table"
if [[ $status != 0 ]]; then
  echo "make test: phase '$name' failed; phase times so far:"
  bash "$0" --print
fi
exit $status
