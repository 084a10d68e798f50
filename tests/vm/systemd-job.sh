#!/bin/bash
# The installed calibd.service under systemd, run by tests/vm/systemd.sh in the test VM
# booted with systemd as PID 1 (CALIBD_VM_INIT=systemd). Installed as a vehicle image would:
# the unit from deploy/systemd/calibd.service.in (paths filled in), the user from
# calibd.sysusers through systemd-sysusers, the config in /etc/calibd, the store in the unit's
# StateDirectory. calibd-sim publishes the drive over LCM on the loopback; calibd-tester drives
# UDS over vcan0. Checks, each a PASS or FAIL line (the exit code counts the failures):
#   - the unit starts (Type=notify: READY=1) as user calibd, with no capabilities, no new
#     privileges and a seccomp filter in force;
#   - a workshop session through it: calibrate to `updated`, commit (the store in
#     /var/lib/calibd, written under ProtectSystem=strict);
#   - SIGKILL during a second session: systemd restarts it (Restart=on-failure) into a clean
#     state: a new main PID, NRestarts=1, idle, DTC 5A0300 (session interrupted), the committed
#     calibration still the one read back over UDS;
#   - `systemctl stop` ends it cleanly (inactive, result success).
set -u
cd "${CALIBD_VM_SHARED:?}" || exit 100
failures=0
pass() { echo "PASS $1"; }
fail() {
  echo "FAIL $1"
  failures=$((failures + 1))
}
check() { # check NAME COMMAND...
  local name=$1
  shift
  if "$@"; then pass "$name"; else fail "$name"; fi
}
wait_for() { # wait_for TENTHS COMMAND...: polls until the command succeeds
  local tenths=$1 i
  shift
  for ((i = 0; i < tenths; i++)); do
    "$@" && return 0
    sleep 0.1
  done
  return 1
}
show() { systemctl show -p "$1" --value calibd; }
tester() { ./calibd-tester --interface vcan0 --p2-ms 2000 --quiet "$@"; }
# UDS answers (0x22 F195) within TRIES half-second attempts: a fresh agent in the emulated guest
# takes a few seconds to serve its first request.
uds_answers() {
  local i
  for ((i = 0; i < $1; i++)); do
    tester read F195 >/dev/null 2>&1 && return 0
    sleep 0.5
  done
  return 1
}
readonly lcm_url="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216"
[ "${CALIBD_VM_INIT:-}" = systemd ] && [ "$(cat /proc/1/comm)" = systemd ] || {
  echo "FAIL not under systemd (run with CALIBD_VM_INIT=systemd: tests/vm/systemd.sh)"
  exit 100
}

# --- installation, as `make install` and the package hooks would ---
install -m755 calibd-agent /usr/local/bin/calibd-agent
sed -e 's|@CMAKE_INSTALL_FULL_BINDIR@|/usr/local/bin|' -e 's|@CMAKE_INSTALL_FULL_SYSCONFDIR@|/etc|' \
  calibd.service.in >/etc/systemd/system/calibd.service
install -D -m644 calibd.sysusers /usr/lib/sysusers.d/calibd.conf
systemd-sysusers || fail "systemd-sysusers"
secret=vmtest-secret-of-this-vehicle-0123456789
install -d -m755 /etc/calibd
printf '%s' "$secret" >/etc/calibd/uds.secret
chown calibd:calibd /etc/calibd/uds.secret
chmod 600 /etc/calibd/uds.secret
printf '%s' "$secret" >/root/tester.secret # the tester's copy: owned by its user (root)
chmod 600 /root/tester.secret
{
  cat calib.yaml
  cat <<YAML
agent:
  lcm_url: "$lcm_url"
  store:
    directory: /var/lib/calibd
  cache_dir: /var/cache/calibd
  min_frames: 60
  min_distance_bins: 1
  max_duration_s: 150
  can:
    enabled: true
    interface: vcan0
  uds:
    secret_file: /etc/calibd/uds.secret
    state_dir: /var/lib/calibd/uds
# 60 pairs of small tags: their bound is beyond the default 0.3 deg / 3 cm
# (kShortSessionRotationBoundDeg, kShortSessionTranslationBoundM, tests/short_session.hpp).
engine:
  verdict:
    max_translation_bound_m: 0.1
    max_rotation_bound_deg: 0.6
YAML
} >/etc/calibd/calibd.yaml
systemctl daemon-reload
systemd-analyze verify /etc/systemd/system/calibd.service || fail "systemd-analyze verify"

# --- the sensors: the drive over LCM udpm on the loopback, looping ---
ip link set lo multicast on && ip route replace 224.0.0.0/4 dev lo
sysctl -q -w net.core.rmem_max=33554432 net.core.rmem_default=4194304
./calibd-sim --replay session.lcmlog --publish-url "$lcm_url" --loops 100 --speed 0.2 \
  --start-delay 0 >sim.log 2>&1 &
sim=$!

# --- start: Type=notify returns once the agent sent READY=1 ---
if ! systemctl start calibd; then
  fail "systemctl start calibd"
  journalctl -u calibd --no-pager | tail -30
  exit 100
fi
pid=$(show MainPID)
pass "calibd.service active, main PID $pid"
status=$(cat "/proc/$pid/status")
check "runs as user calibd" test "$(stat -c %U "/proc/$pid")" = calibd
check "no effective capabilities" grep -q $'^CapEff:\t0000000000000000$' <<<"$status"
check "no new privileges" grep -q $'^NoNewPrivs:\t1$' <<<"$status"
check "seccomp filter in force" grep -q $'^Seccomp:\t2$' <<<"$status"
check "UDS answers on vcan0" uds_answers 10
# The LiDAR references build after READY=1, under the poll loop's priority (the unit lets the
# agent lower its own build thread's priority: setpriority).
check "LiDAR references built at nice 10" wait_for 1200 \
  sh -c 'journalctl -u calibd --no-pager | grep -q "LiDAR detector ready: .* (at nice 10)"'

# --- a workshop session to a committed calibration ---
# The agent answers at once; its start routine refuses (0x22 conditionsNotCorrect) until it hears
# both sensors, which calibd-sim, starting in the emulated guest, may not have sent yet.
for ((attempt = 0; attempt < 60; attempt++)); do
  out=$(tester --secret /root/tester.secret calibrate --max-duration 150 2>&1)
  code=$?
  [ "$code" -eq 5 ] && grep -q "0x22 conditionsNotCorrect" <<<"$out" || break
  sleep 1
done
echo "$out" | sed 's/^/  calibrate: /'
check "calibrate: updated (exit $code)" grep -q '^verdict: updated$' <<<"$out"
check "commit" tester --secret /root/tester.secret commit
before=$(tester read FD00)
echo "  $before"
check "store written in the state directory" test -f /var/lib/calibd/current.json

# --- SIGKILL during the next session: systemd restarts the agent ---
check "calibd-sim still publishing" kill -0 "$sim"
free -m | sed 's/^/  /'
check "second session started" tester --secret /root/tester.secret calibrate --no-wait
sleep 3
check "a session marker while collecting" test -f /var/lib/calibd/session_in_progress
kill -KILL "$pid"
restarted() { [ "$(show ActiveState)" = active ] && [ "$(show MainPID)" != "$pid" ] &&
  [ "$(show MainPID)" != 0 ]; }
check "restarted by systemd within 60 s" wait_for 600 restarted
check "NRestarts=1" test "$(show NRestarts)" = 1
echo "  new main PID $(show MainPID)"
check "UDS answers after the restart" uds_answers 20
# The first start built the LiDAR references and kept them in the unit's CacheDirectory=; the
# restart takes them from there.
check "references kept in /var/cache/calibd" test -f /var/cache/calibd/lidar-references.bin
check "the restarted agent's references from the cache" wait_for 600 \
  sh -c 'journalctl -u calibd --no-pager | grep -q "reference descriptors from the cache"'
results=$(tester results 2>&1)
echo "$results" | sed 's/^/  results: /'
# A fresh agent has no routine to report (0x24) until a calibration is started.
check "no session running after the restart" grep -Eq '^status: (idle|aborted)$|0x24 requestSequenceError' <<<"$results"
dtcs=$(tester dtc 2>&1)
echo "$dtcs" | sed 's/^/  dtc: /'
check "DTC 5A0300 session interrupted" grep -q '(0x5A0300)' <<<"$dtcs"
check "the committed calibration still in use" test "$(tester read FD00)" = "$before"

# --- a clean stop ---
check "systemctl stop" systemctl stop calibd
check "stopped cleanly (result success)" test "$(show Result)" = success
journalctl -u calibd --no-pager -o cat | tail -15 | sed 's/^/  journal: /'
journalctl -k --no-pager -o cat | grep -iE 'oom|killed|memory' | tail -5 | sed 's/^/  kernel: /'
kill -0 "$sim" 2>/dev/null || { wait "$sim"; echo "  calibd-sim ended with exit code $?"; }
echo "systemd-job: $failures failure(s)"
exit "$failures"
