#!/usr/bin/env bash
# run_fuzz.sh <fuzz executable> <seed corpus dir> <work dir> <seconds> [libFuzzer flags...]
# Fuzzes for <seconds> from a copy of the seed corpus (<work dir>/corpus: the repository's corpus
# is never written), one process, crash inputs into <work dir>/artifacts/, the log in
# <work dir>/fuzz.log. Prints one line: name, executions, exec/s, cov, ft, corpus size, result.
# Exit status: libFuzzer's (non-zero on a crash, leak, timeout or out-of-memory).
set -uo pipefail
exe=$1 seeds=$2 work=$3 seconds=$4
shift 4
rm -rf "$work"
mkdir -p "$work/corpus" "$work/artifacts" "${TMPDIR:-/tmp}"
cp -r "$seeds"/. "$work/corpus/" 2>/dev/null || true
# -timeout: one input taking 10 s is a hang; -rss_limit_mb: a lying size that allocates
# gigabytes is an out-of-memory crash (libFuzzer's malloc limit defaults to the same 2 GB).
"$exe" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
  -artifact_prefix="$work/artifacts/" "$@" "$work/corpus" >"$work/fuzz.log" 2>&1
status=$?
name=$(basename "$exe")
execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/fuzz.log" | tail -1)
rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$work/fuzz.log" | tail -1)
last=$(grep -E '^#[0-9]+.*cov: ' "$work/fuzz.log" | tail -1)
cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
units=$(sed -n 's/.* corp: \([0-9]*\)\/.*/\1/p' <<<"$last")
result=ok
[ "$status" -ne 0 ] && result="FAILED (status $status; $(ls "$work/artifacts" | head -3 | tr '\n' ' '))"
printf '%-26s %12s %8s %7s %7s %6s  %s\n' "$name" "${execs:-?}" "${rate:-?}" "${cov:-?}" \
  "${ft:-?}" "${units:-?}" "$result"
if [ "$status" -ne 0 ]; then
  grep -E 'ERROR|SUMMARY|invariant|#[0-9]+ in ' "$work/fuzz.log" | head -30 >&2
fi
exit "$status"
