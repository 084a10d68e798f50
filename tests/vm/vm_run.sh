#!/usr/bin/env bash
# Runs a bash job inside calibd's test VM (Debian's kernel under qemu, TCG):
#   tests/vm/vm_run.sh JOB_SCRIPT SHARED_DIR [TIMEOUT_S]       (TIMEOUT_S default 300)
#
# The job runs as root in the guest, chrooted into the host's root filesystem (read-only, with an
# in-memory overlay), working directory SHARED_DIR, which is the one folder shared read-write with
# the host (created if missing; results go there). vcan0, vcan1 and the gpio-sim chip calibd-sim
# are ready before it starts; see guest-init.sh for the environment it gets.
#
# Exit code: the job's. When the VM gives none: 97 qemu could not start, 98 timed out, 99 the VM
# ended without running the job to its end (did not boot, set-up failed, kernel panic); 2 usage.
# The guest console goes to SHARED_DIR/vm-console.log and is printed when anything fails
# (always with CALIBD_VM_VERBOSE=1).
# Assets come from prepare.sh (run here first; a no-op once built) in $CALIBD_VM_CACHE, default
# build/vm of this checkout. CALIBD_VM_MEM (MiB, default 1024) and CALIBD_VM_CPUS (default 2);
# CALIBD_VM_INIT=systemd boots the guest with systemd and runs the job as a service.
# A second shared folder, SHARED_DIR/slow-store, is written through qemu's I/O throttling
# (CALIBD_VM_SLOW_BPS bytes written per second, default 2048): slow storage, mounted in the guest
# at /slow-store.
set -uo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
cache=${CALIBD_VM_CACHE:-$repo/build/vm}

err() { echo "vm_run: ERROR: $*" >&2; }
if [ $# -lt 2 ] || [ $# -gt 3 ]; then
  echo "usage: $0 JOB_SCRIPT SHARED_DIR [TIMEOUT_S]" >&2
  exit 2
fi
job_src=$1
timeout_s=${3:-300}
[ -f "$job_src" ] || {
  err "no job script $job_src"
  exit 2
}
case $timeout_s in '' | *[!0-9]*)
  err "timeout must be whole seconds, got '$timeout_s'"
  exit 2
  ;;
esac
mkdir -p "$2" || exit 2
shared=$(cd "$2" && pwd -P)
# The paths travel on the kernel command line, which splits at white space.
case $shared in *[[:space:]]*)
  err "the shared folder's path must not contain white space: $shared"
  exit 2
  ;;
esac
command -v qemu-system-x86_64 >/dev/null || {
  err "qemu-system-x86_64 not found; run deploy/install-deps.sh"
  exit 97
}

CALIBD_VM_CACHE=$cache "$here/prepare.sh" >"$shared/vm-prepare.log" 2>&1 || {
  cat "$shared/vm-prepare.log" >&2
  err "preparing the VM assets failed"
  exit 97
}
# shellcheck source=/dev/null
. "$cache/vm.env"

# The job is copied into the shared folder: the guest sees the host's files, but not the host's
# /tmp (the guest's is its own), where a caller's job may live.
job=$shared/.vm-job.sh
cp "$job_src" "$job"
console=$shared/vm-console.log
rm -f "$shared/vm-exit-code" "$console"

# CALIBD_VM_INIT=systemd: the host's systemd boots the guest and runs the job as a service
# (guest-init.sh), for jobs that need systemd itself (tests/vm/systemd-job.sh).
init_arg=
case ${CALIBD_VM_INIT:-} in
  '') ;;
  systemd) init_arg=" calibd.init=systemd" ;;
  *)
    err "CALIBD_VM_INIT must be empty or systemd, got '$CALIBD_VM_INIT'"
    exit 2
    ;;
esac
mkdir -p "$shared/slow-store" || exit 2
slow_bps=${CALIBD_VM_SLOW_BPS:-2048}
case $slow_bps in '' | *[!0-9]*)
  err "CALIBD_VM_SLOW_BPS must be whole bytes per second, got '$slow_bps'"
  exit 2
  ;;
esac
t0=$(date +%s.%N)
# -nodefaults: no network, display or monitor; the serial port is the console; -no-reboot turns a
# guest reboot or panic (panic=-1) into qemu exiting. KVM does not boot a stock kernel on our
# machines (nor is /dev/kvm always there): TCG, which needs no privilege.
timeout -k 5 "$timeout_s" qemu-system-x86_64 -accel tcg,thread=multi -cpu max -M pc \
  -m "${CALIBD_VM_MEM:-1024}" -smp "${CALIBD_VM_CPUS:-2}" \
  -nodefaults -no-user-config -display none -no-reboot -serial stdio \
  -kernel "$CALIBD_VM_KERNEL_IMAGE" -initrd "$CALIBD_VM_INITRAMFS" \
  -virtfs local,path=/,mount_tag=hostroot,security_model=none,readonly=on,multidevs=remap \
  -virtfs "local,path=$shared,mount_tag=shared,security_model=none,multidevs=remap" \
  -fsdev "local,id=slowstore,path=$shared/slow-store,security_model=none,throttling.bps-write=$slow_bps" \
  -device virtio-9p-pci,fsdev=slowstore,mount_tag=slowstore \
  -append "console=ttyS0 quiet panic=-1 calibd.job=$job calibd.shared=$shared$init_arg" \
  </dev/null >"$console" 2>&1
qemu_rc=$?
sed -i 's/\r$//' "$console" 2>/dev/null
wall=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')

show_console() {
  echo "----- guest console ($console) -----"
  cat "$console"
  echo "----- end of guest console -----"
}

if [ "$qemu_rc" = 124 ] || [ "$qemu_rc" = 137 ]; then
  show_console
  err "the VM timed out after $timeout_s s (job $job_src)"
  exit 98
fi
if [ ! -f "$shared/vm-exit-code" ]; then
  show_console
  if grep -q '=== job ' "$console"; then
    err "the VM ended before the job finished (qemu exit $qemu_rc, ${wall} s)"
  elif [ "$qemu_rc" != 0 ] && ! grep -q 'calibd-vm:' "$console"; then
    err "qemu failed (exit $qemu_rc) before the guest started"
    exit 97
  else
    err "the VM did not boot to the job (qemu exit $qemu_rc, ${wall} s); see the console above"
  fi
  exit 99
fi
rc=$(cat "$shared/vm-exit-code")
if [ "$rc" != 0 ] || [ "${CALIBD_VM_VERBOSE:-0}" = 1 ]; then
  show_console
else
  # Success: only what the job printed.
  sed -n '/^=== job /,$p' "$console"
fi
echo "vm_run: job exit $rc, VM wall clock ${wall} s (kernel $CALIBD_VM_ABI)"
exit "$rc"
