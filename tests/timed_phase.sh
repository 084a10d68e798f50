#!/usr/bin/env bash
# `make test`'s phase clock: runs one phase's command, appends its wall time and the machine's CPU
# time over it to the table in $CALIBD_PHASES (one "seconds<TAB>name<TAB>status<TAB>cpu seconds"
# line per phase), and exits with the command's status. `timed_phase.sh --print` prints the table
# with its totals; the CPU column (every process's, from /proc/stat) over the wall time times the
# number of cores says how busy the machine was: a phase near 100 % gets shorter only with less
# work, one well below it from more running at once.
set -uo pipefail
table=${CALIBD_PHASES:-build/phase-times.tsv}
if [[ ${1:-} == --print ]]; then
  [[ -f $table ]] || exit 0
  awk -F'\t' -v cores="$(nproc)" '
    function busy(c, w) { return w > 0 ? sprintf("%3d %%", 100 * c / (w * cores)) : "  - %" }
    { printf "  %-42s %6d s  CPU %6d s %s  %s\n", $2, $1, $4, busy($4, $1), $3; wall += $1; cpu += $4 }
    END { printf "  %-42s %6d s  CPU %6d s %s  (%.1f min, %d cores)\n", "total", wall, cpu,
                 busy(cpu, wall), wall / 60, cores }' "$table"
  exit 0
fi
name=$1
shift
mkdir -p "$(dirname "$table")"
# Busy CPU time of the whole machine so far, in seconds (user, nice, system, irq, softirq, steal).
busy_s() {
  awk -v hz="$(getconf CLK_TCK)" '/^cpu / { print ($2 + $3 + $4 + $7 + $8 + $9) / hz }' /proc/stat
}
start=$(date +%s)
cpu_start=$(busy_s)
"$@"
status=$?
cpu=$(awk -v a="$cpu_start" -v b="$(busy_s)" 'BEGIN { printf "%d", b - a }')
echo -e "$(($(date +%s) - start))\t$name\t$([[ $status == 0 ]] && echo ok || echo "failed ($status)")\t$cpu" >> "$table"
if [[ $status != 0 ]]; then
  echo "make test: phase '$name' failed; phase times so far:"
  bash "$0" --print
fi
exit $status
