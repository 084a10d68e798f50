#!/bin/sh
# /init (PID 1) of calibd's test VM, run by busybox sh from the initramfs that prepare.sh builds.
#
# 1. Loads the modules listed in /etc/modules.load (SocketCAN, ISO-TP, vcan, gpio-sim, 9p, overlay).
# 2. Builds the job's root: the host's / (9p tag "hostroot", read-only) under a tmpfs overlay, so
#    host-built binaries and their libraries run unchanged and the job may write anywhere (the
#    writes stay in guest memory); fresh /tmp, /run, /dev; the host folder given as
#    calibd.shared= (9p tag "shared", read-write) mounted at the same path; the throttled share
#    (9p tag "slowstore", vm_run.sh) at /slow-store.
# 3. Fixtures: lo up; vcan0 and vcan1 (CAN FD MTU); a gpio-sim chip labelled calibd-sim with 8
#    lines, the first four named interlock, start_button, status_lamp, spare.
# 4. Runs `bash JOB` chrooted into that root, in the shared folder, with a clean environment:
#      CALIBD_VM=1, CALIBD_VM_SHARED (the shared folder), CALIBD_VM_GPIOCHIP (e.g. gpiochip0),
#      CALIBD_VM_GPIOSIM (the simulator's sysfs folder: sim_gpioN/{pull,value}).
# 5. Writes the job's exit code to SHARED/vm-exit-code and powers off. Nothing is written there
#    when the VM could not set up, which vm_run.sh reports as a VM failure.
# With calibd.init=systemd, step 4 differs: the root becomes the real root (switch_root) and the
# host's systemd boots it as PID 1, with the job as the one unit asked for
# (calibd-vm-job.service, the same environment plus CALIBD_VM_INIT=systemd), so that a job can
# run calibd.service as a vehicle would; the service writes the exit code and powers off.
# Kernel command line: calibd.job=/abs/job.sh calibd.shared=/abs/host/folder (no spaces)
# [calibd.init=systemd].
PATH=/bin:/sbin
export PATH
R=/newroot

say() { echo "calibd-vm: $*"; }
uptime_s() { cut -d' ' -f1 /proc/uptime; }
off() {
  sync
  poweroff -f
  sleep 10
}
fatal() {
  say "FATAL: $*"
  off
}

mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev

while read -r ko; do
  insmod "/lib/modules/$ko" || say "FAIL: insmod $ko"
done </etc/modules.load

job=
shared=
init=
for arg in $(cat /proc/cmdline); do
  case $arg in
    calibd.job=*) job=${arg#*=} ;;
    calibd.shared=*) shared=${arg#*=} ;;
    calibd.init=*) init=${arg#*=} ;;
  esac
done
[ -n "$job" ] && [ -n "$shared" ] || fatal "calibd.job= or calibd.shared= missing on the command line"

# --- the job's root ---
p9=trans=virtio,version=9p2000.L,msize=512000
mkdir -p /host /rw
mount -t 9p -o "$p9,ro,cache=loose" hostroot /host || fatal "cannot mount the host root (9p)"
mount -t tmpfs -o mode=755 tmpfs /rw
mkdir -p /rw/upper /rw/work
mount -t overlay overlay -o lowerdir=/host,upperdir=/rw/upper,workdir=/rw/work "$R" ||
  fatal "cannot mount the overlay root"
mount -t proc proc "$R/proc"
mount -t sysfs sysfs "$R/sys"
mount -t configfs configfs "$R/sys/kernel/config" || say "FAIL: configfs"
mount -t devtmpfs devtmpfs "$R/dev"
mkdir -p "$R/dev/pts" "$R/dev/shm"
mount -t devpts devpts "$R/dev/pts"
mount -t tmpfs tmpfs "$R/dev/shm"
mount -t tmpfs tmpfs "$R/tmp"
mount -t tmpfs tmpfs "$R/run"
# Last, as it may lie under /tmp or /run of the host.
mkdir -p "$R$shared"
mount -t 9p -o "$p9,cache=none" shared "$R$shared" || fatal "cannot mount the shared folder (9p)"
mkdir -p "$R/slow-store"
mount -t 9p -o "$p9,cache=none" slowstore "$R/slow-store" || say "FAIL: the slow-store share (9p)"

# --- fixtures, made with the host's iproute2 (busybox ip knows no vcan) ---
chroot "$R" ip link set lo up
for n in 0 1; do
  chroot "$R" ip link add dev "vcan$n" type vcan &&
    chroot "$R" ip link set "vcan$n" mtu 72 up || say "FAIL: vcan$n"
done

sim=$R/sys/kernel/config/gpio-sim/calibd
chip=
simdir=
if mkdir "$sim" "$sim/bank0"; then
  echo calibd-sim >"$sim/bank0/label"
  echo 8 >"$sim/bank0/num_lines"
  i=0
  for name in interlock start_button status_lamp spare; do
    mkdir "$sim/bank0/line$i"
    echo "$name" >"$sim/bank0/line$i/name"
    i=$((i + 1))
  done
  if echo 1 >"$sim/live"; then
    chip=$(cat "$sim/bank0/chip_name")
    simdir=/sys/devices/platform/$(cat "$sim/dev_name")/$chip
  else
    say "FAIL: gpio-sim chip did not go live"
  fi
else
  say "FAIL: no gpio-sim in configfs"
fi

say "ready at $(uptime_s) s: vcan0 vcan1, gpio-sim $chip (calibd-sim)"
if [ "$init" = systemd ]; then
  wrapper=/etc/calibd-vm-job.sh
  cat >"$R$wrapper" <<JOB
#!/bin/bash
cd "$shared" || exit 1
echo "=== job $job (under systemd)"
/bin/bash "$job" </dev/null
rc=\$?
echo "=== job exit \$rc at \$(cut -d' ' -f1 /proc/uptime) s"
echo "\$rc" >"$shared/vm-exit-code.tmp" && mv "$shared/vm-exit-code.tmp" "$shared/vm-exit-code"
sync
systemctl poweroff --force --force
JOB
  cat >"$R/etc/systemd/system/calibd-vm-job.service" <<UNIT
[Unit]
Description=calibd test VM job
After=basic.target
[Service]
Type=oneshot
Environment=HOME=/root TERM=dumb LANG=C.UTF-8 CALIBD_VM=1 CALIBD_VM_INIT=systemd
Environment=CALIBD_VM_SHARED=$shared CALIBD_VM_GPIOCHIP=$chip CALIBD_VM_GPIOSIM=$simdir
ExecStart=/bin/bash $wrapper
StandardOutput=tty
StandardError=tty
TTYPath=/dev/console
UNIT
  exec switch_root "$R" /lib/systemd/systemd --unit=calibd-vm-job.service --log-level=warning \
    --show-status=false
fi
echo "=== job $job"
chroot "$R" /usr/bin/env -i -C "$shared" HOME=/root TERM=dumb LANG=C.UTF-8 \
  PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
  CALIBD_VM=1 CALIBD_VM_SHARED="$shared" CALIBD_VM_GPIOCHIP="$chip" CALIBD_VM_GPIOSIM="$simdir" \
  /bin/bash "$job" </dev/null
rc=$?
echo "=== job exit $rc at $(uptime_s) s"
echo "$rc" >"$R$shared/vm-exit-code.tmp" && mv "$R$shared/vm-exit-code.tmp" "$R$shared/vm-exit-code"
sync
umount "$R$shared"
off
