#!/bin/bash
# VM smoke test (ctest vm_smoke), run inside the test VM by vm_run.sh: the kernel's CAN stack and
# the gpio-sim chip work with real tools, so the drivers' VM tests can rely on them.
#   (a) raw CAN: a frame sent with cansend on vcan0 reaches candump
#   (b) ISO-TP: a 40-byte message (first frame, flow control, consecutive frames) goes from
#       isotpsend to isotprecv through the kernel's can-isotp
#   (c) GPIO: libgpiod's tools see the chip calibd-sim and its line names; a level pulled on the
#       simulator side reads back through gpioget; a level driven with gpioset shows on the
#       simulator side
# Every check runs; the exit code is the number of failed ones, each named on a FAIL line.
set -u
failed=()
pass() { echo "PASS $1"; }
fail() {
  echo "FAIL $1: $2"
  failed+=("$1")
}
# Polls a command until it succeeds, up to $1 tenths of a second.
wait_for() {
  local tenths=$1
  shift
  for ((i = 0; i < tenths; i++)); do
    "$@" && return 0
    sleep 0.1
  done
  return 1
}
nonempty() { [ -s "$1" ]; }
out=/tmp/smoke
mkdir -p "$out"
echo "kernel $(uname -r), uptime $(cut -d' ' -f1 /proc/uptime) s"

# --- (a) raw CAN on vcan0 ---
check_raw_can() {
  local name="(a) raw CAN vcan0"
  ip -details link show vcan0 | grep -q vcan || {
    fail "$name" "no vcan0 interface"
    return
  }
  ip link show vcan1 >/dev/null 2>&1 || fail "(a) raw CAN vcan1" "no vcan1 interface"
  timeout 20 candump -n 1 -L vcan0 >"$out/candump.txt" &
  local dump=$!
  # candump takes the first frame it sees and exits; resend until it has started listening.
  for ((i = 0; i < 50; i++)); do
    cansend vcan0 123#DEADBEEF || break
    wait_for 2 nonempty "$out/candump.txt" && break
  done
  wait "$dump"
  if grep -q ' vcan0 123#DEADBEEF$' "$out/candump.txt"; then
    pass "$name: $(cat "$out/candump.txt")"
  else
    fail "$name" "candump got '$(cat "$out/candump.txt")', want 'vcan0 123#DEADBEEF'"
  fi
}

# --- (b) ISO-TP, tester 0x7E0 -> ECU 0x7E8 (UDS physical addressing) ---
check_isotp() {
  local name="(b) ISO-TP 40-byte message"
  local payload
  payload=$(seq 1 40 | awk '{ printf "%s%02X", (NR > 1 ? " " : ""), $1 }')
  timeout 20 isotprecv -s 7e8 -d 7e0 vcan0 >"$out/isotp.txt" &
  local recv=$!
  # The receiver is listening once its socket filter for 0x7E0 is in the kernel's receive list.
  wait_for 50 grep -qi 'vcan0 *0*7e0 ' /proc/net/can/rcvlist_sff ||
    echo "note: no 0x7E0 filter seen in /proc/net/can/rcvlist_sff; sending anyway"
  local sent=0
  for ((i = 0; i < 3; i++)); do
    if echo "$payload" | isotpsend -s 7e0 -d 7e8 vcan0; then
      sent=1
      break
    fi
    sleep 0.5
  done
  wait "$recv"
  local got
  got=$(tr -s ' ' <"$out/isotp.txt" | sed 's/ *$//')
  if [ "$sent" = 1 ] && [ "$got" = "$payload" ]; then
    pass "$name: $got"
  else
    fail "$name" "sent=$sent, received '$got', want '$payload'"
  fi
}

# --- (c) GPIO through libgpiod (gpiod 1.6 tools) on the gpio-sim chip ---
# Offset of a named line on the chip, found by libgpiod itself.
line_offset() {
  local found
  found=$(gpiofind "$1") || return 1
  [ "${found% *}" = "$CALIBD_VM_GPIOCHIP" ] || return 1
  echo "${found#* }"
}
check_gpio() {
  local chip=${CALIBD_VM_GPIOCHIP:-} sim=${CALIBD_VM_GPIOSIM:-}
  if [ -z "$chip" ] || [ ! -d "$sim" ]; then
    fail "(c) GPIO" "no gpio-sim chip (CALIBD_VM_GPIOCHIP='$chip', CALIBD_VM_GPIOSIM='$sim')"
    return
  fi
  # (each program start costs about half a second in the VM: run each tool once)
  local detected info
  detected=$(gpiodetect)
  if grep -q "^$chip \[calibd-sim\]" <<<"$detected"; then
    pass "(c) GPIO gpiodetect: $(grep "^$chip " <<<"$detected")"
  else
    fail "(c) GPIO gpiodetect" "no '$chip [calibd-sim]' in: $(tr '\n' ';' <<<"$detected")"
  fi
  info=$(gpioinfo "$chip")
  local line names_ok=1
  for line in interlock start_button status_lamp spare; do
    if [[ $info != *"\"$line\""* ]]; then
      fail "(c) GPIO line names" "gpioinfo $chip shows no line \"$line\""
      names_ok=0
    fi
  done
  [ "$names_ok" = 0 ] || pass "(c) GPIO line names: interlock start_button status_lamp spare"

  # input: the simulator pulls the line, the consumer reads it
  local in
  if in=$(line_offset interlock); then
    local pull want got ok=1
    for pull in pull-up pull-down pull-up; do
      echo "$pull" >"$sim/sim_gpio$in/pull"
      want=$([ "$pull" = pull-up ] && echo 1 || echo 0)
      got=$(gpioget "$chip" "$in")
      [ "$got" = "$want" ] || {
        fail "(c) GPIO input interlock" "simulator $pull, gpioget read '$got'"
        ok=0
      }
    done
    [ "$ok" = 0 ] || pass "(c) GPIO input interlock (line $in): simulator pulls read back by gpioget"
  else
    fail "(c) GPIO input" "gpiofind found no line interlock on $chip"
  fi

  # output: the consumer drives the line, the simulator sees it (pulled the other way meanwhile)
  local lamp
  if lamp=$(line_offset status_lamp); then
    local level ok=1 holder
    for level in 1 0; do
      local against="pull-up"
      [ "$level" = 0 ] || against="pull-down"
      echo "$against" >"$sim/sim_gpio$lamp/pull"
      gpioset --mode=signal "$chip" "$lamp=$level" &
      holder=$!
      if ! wait_for 50 grep -qx "$level" "$sim/sim_gpio$lamp/value"; then
        fail "(c) GPIO output status_lamp" "gpioset $level, simulator value $(cat "$sim/sim_gpio$lamp/value")"
        ok=0
      fi
      kill "$holder"
      wait "$holder" 2>/dev/null
    done
    [ "$ok" = 0 ] || pass "(c) GPIO output status_lamp (line $lamp): gpioset 1 and 0 seen by the simulator"
  else
    fail "(c) GPIO output" "gpiofind found no line status_lamp on $chip"
  fi
}

check_raw_can
check_isotp
check_gpio

if [ ${#failed[@]} -eq 0 ]; then
  echo "smoke: all checks passed"
  exit 0
fi
echo "smoke: ${#failed[@]} check(s) failed: ${failed[*]}"
exit "${#failed[@]}"
