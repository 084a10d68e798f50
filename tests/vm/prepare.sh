#!/usr/bin/env bash
# Prepares what the test VM boots into a cache directory:
#   tests/vm/prepare.sh [CACHE_DIR]      (default: $CALIBD_VM_CACHE, else build/vm of this checkout)
#
# - Debian's own kernel (linux-image-<abi>-amd64, fetched with `apt-get download`, never installed):
#   its vmlinuz and the modules the tests need (SocketCAN: can, can-raw, can-isotp, vcan; the 9p
#   share: virtio PCI + 9p; overlayfs; configfs for gpio-sim).
# - gpio-sim.ko, which Debian does not build (CONFIG_GPIO_SIM is off): compiled out of tree from the
#   matching linux-source-<major.minor> package against the installed linux-headers-<abi>.
# - an initramfs: busybox-static, those modules in load order, and tests/vm/guest-init.sh as /init.
#
# Idempotent: each stage writes a stamp naming its inputs (kernel ABI, module list, the init's
# checksum) and is skipped when the stamp matches, so a second run only compares two stamps.
# Needs no root: apt-get download, dpkg-deb, kbuild and cpio run as any user (the Debian packages
# come from deploy/install-deps.sh). CALIBD_VM_KERNEL=<abi> (e.g. 6.1.0-56-amd64) pins the kernel.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
cache=${1:-${CALIBD_VM_CACHE:-$repo/build/vm}}

say() { echo "vm-prepare: $*"; }
die() {
  echo "vm-prepare: ERROR: $*" >&2
  exit 1
}

# Modules the guest loads (their dependencies are added in order by modprobe --show-depends).
GUEST_MODULES=(can can-raw can-isotp can-bcm vcan configfs gpio-sim virtio_pci 9pnet_virtio 9p
  overlay)
# Bump when the kernel stage's recipe changes, to rebuild caches made by an older one.
KERNEL_RECIPE=1

for tool in apt-get apt-cache dpkg-deb dpkg-query depmod modprobe make cpio gzip xz tar flock \
  sha256sum; do
  command -v "$tool" >/dev/null || die "'$tool' not found; run deploy/install-deps.sh"
done
[ -x /bin/busybox ] || die "/bin/busybox missing; install busybox-static (deploy/install-deps.sh)"
if ldd /bin/busybox >/dev/null 2>&1; then
  die "/bin/busybox is dynamically linked; the initramfs needs busybox-static"
fi

mkdir -p "$cache"
cache=$(cd "$cache" && pwd)
# One preparation at a time per cache (parallel ctest runs, two build trees sharing it).
[ -e "$cache/.lock" ] || : >"$cache/.lock"
exec 9<"$cache/.lock"
flock 9
# Left-overs of a preparation that was killed.
rm -rf "$cache"/work.*

# The kernel ABI: pinned, else the one the installed linux-headers-amd64 points at (so the headers
# for the out-of-tree build are there), else the archive's current linux-image-amd64.
kernel_abi() {
  if [ -n "${CALIBD_VM_KERNEL:-}" ]; then
    echo "$CALIBD_VM_KERNEL"
    return
  fi
  local dep
  dep=$(dpkg-query -W -f='${Depends}' linux-headers-amd64 2>/dev/null |
    grep -o 'linux-headers-[0-9][^ ,]*-amd64' | head -n1 || true)
  if [ -n "$dep" ]; then
    echo "${dep#linux-headers-}"
    return
  fi
  apt-cache depends linux-image-amd64 2>/dev/null |
    awk '$1 == "Depends:" && $2 ~ /^linux-image-[0-9]/ { sub("linux-image-", "", $2); print $2; exit }'
}

abi=$(kernel_abi)
[ -n "$abi" ] || die "cannot tell which Debian kernel to use (no linux-headers-amd64 installed, \
no linux-image-amd64 in the apt lists); run deploy/install-deps.sh"
kdir=$cache/kernel-$abi
kernel_stamp="abi=$abi recipe=$KERNEL_RECIPE modules=${GUEST_MODULES[*]}"

work=""
cleanup() { [ -z "$work" ] || rm -rf "$work"; }
trap cleanup EXIT

# Downloads one package into the current directory; the exact version first, else the candidate.
fetch_deb() {
  local name=$1 version=${2:-}
  if [ -n "$version" ] && apt-get download -q "$name=$version" >/dev/null 2>&1; then return 0; fi
  apt-get download -q "$name" >/dev/null 2>&1 ||
    die "apt-get download $name failed (apt lists stale? run apt-get update as root)"
}

build_kernel_stage() {
  local headers=/usr/src/linux-headers-$abi
  [ -f "$headers/Makefile" ] || die "$headers missing: install linux-headers-$abi \
(deploy/install-deps.sh installs linux-headers-amd64)"
  local version series
  version=$(dpkg-query -W -f='${Version}' "linux-headers-$abi" 2>/dev/null || true)
  series=$(echo "$abi" | cut -d. -f1,2)

  work=$(mktemp -d "$cache/work.XXXXXX")
  say "kernel $abi: downloading linux-image-$abi and linux-source-$series ${version:+($version)}"
  (cd "$work" && fetch_deb "linux-image-$abi" "$version" && fetch_deb "linux-source-$series" "$version")

  say "extracting the kernel and its modules"
  mkdir -p "$work/root" "$work/src"
  dpkg-deb -x "$work"/linux-image-"$abi"_*.deb "$work/root"
  [ -f "$work/root/boot/vmlinuz-$abi" ] || die "linux-image-$abi holds no boot/vmlinuz-$abi"

  # gpio-sim needs three files of the source: the driver, gpiolib's private header and the
  # interrupt simulator (IRQ_SIM is a hidden option Debian's kernel does not build in).
  say "building gpio-sim.ko out of tree"
  dpkg-deb --fsys-tarfile "$work"/linux-source-"$series"_*.deb |
    tar -x -C "$work/src" --wildcards './usr/src/linux-source-*.tar.xz'
  local tarball
  tarball=$(ls "$work"/src/usr/src/linux-source-*.tar.xz)
  tar -xJf "$tarball" -C "$work/src" --strip-components=1 \
    "linux-source-$series/drivers/gpio/gpio-sim.c" "linux-source-$series/drivers/gpio/gpiolib.h" \
    "linux-source-$series/kernel/irq/irq_sim.c"
  rm -f "$tarball"
  local mod=$work/gpio-sim
  mkdir -p "$mod"
  # The module's own object is renamed so that the module itself can be called gpio-sim.
  cp "$work/src/drivers/gpio/gpio-sim.c" "$mod/gpio-sim-main.c"
  cp "$work/src/drivers/gpio/gpiolib.h" "$work/src/kernel/irq/irq_sim.c" "$mod/"
  # irq_sim.c calls irq_to_desc(), which 6.1 does not export to modules; generic_handle_irq()
  # reaches the same handler (handle_simple_irq) through an exported function.
  sed -i 's/handle_simple_irq(irq_to_desc(\([a-z_]*\)))/generic_handle_irq(\1)/' "$mod/irq_sim.c"
  printf 'obj-m := gpio-sim.o\ngpio-sim-y := gpio-sim-main.o irq_sim.o\n' >"$mod/Kbuild"
  make -s -C "$headers" M="$mod" -j2 modules 2>&1 | grep -v 'Skipping BTF generation' || true
  [ -f "$mod/gpio-sim.ko" ] || die "gpio-sim.ko did not build (see the messages above)"
  install -D -m644 "$mod/gpio-sim.ko" "$work/root/lib/modules/$abi/extra/gpio-sim.ko"
  depmod -b "$work/root" "$abi"

  # Keep only what the guest loads, in dependency order, uncompressed (busybox insmod).
  local out=$work/stage
  mkdir -p "$out/modules"
  : >"$out/modules.load"
  local m deps line path base
  for m in "${GUEST_MODULES[@]}"; do
    deps=$(modprobe -d "$work/root" -S "$abi" --show-depends "$m") ||
      die "module $m not found in linux-image-$abi"
    while read -r line; do
      # "insmod /path/to/x.ko [options]" for a module, "builtin x" for one built in
      case $line in
        insmod\ *) path=$(echo "$line" | awk '{print $2}') ;;
        *) continue ;;
      esac
      base=$(basename "$path")
      case $base in
        *.ko.xz) base=${base%.xz} && xz -dc "$path" >"$out/modules/$base" ;;
        *.ko.zst) base=${base%.zst} && zstd -qdc "$path" >"$out/modules/$base" ;;
        *.ko) cp "$path" "$out/modules/$base" ;;
      esac
      grep -qxF "$base" "$out/modules.load" || echo "$base" >>"$out/modules.load"
    done <<<"$deps"
  done
  cp "$work/root/boot/vmlinuz-$abi" "$out/vmlinuz"
  echo "$kernel_stamp" >"$out/stamp"
  rm -rf "$kdir"
  mv "$out" "$kdir"
  rm -rf "$work"
  work=""
}

build_initramfs() {
  local root
  work=$(mktemp -d "$cache/work.XXXXXX")
  root=$work/root
  mkdir -p "$root"/{bin,sbin,dev,proc,sys,tmp,run,etc,lib/modules,newroot}
  cp /bin/busybox "$root/bin/busybox"
  local applet
  for applet in $(/bin/busybox --list); do
    [ -e "$root/bin/$applet" ] || ln -s busybox "$root/bin/$applet"
  done
  cp "$kdir"/modules/*.ko "$root/lib/modules/"
  cp "$kdir/modules.load" "$root/etc/modules.load"
  install -m755 "$here/guest-init.sh" "$root/init"
  # No /dev/console here: Debian's kernel carries a built-in initramfs with it, ours is
  # unpacked over it (and making device nodes would need root).
  (cd "$root" && find . -print0 | cpio --null -o -H newc -R 0:0 --quiet) | gzip -1 >"$work/initramfs"
  mv "$work/initramfs" "$cache/initramfs-$abi.cpio.gz"
  echo "$initramfs_stamp" >"$cache/initramfs-$abi.stamp"
  rm -rf "$work"
  work=""
}

t0=$(date +%s)
did=0
# Assets of another kernel ABI (an older linux-headers-amd64) are of no more use.
for old in "$cache"/kernel-* "$cache"/initramfs-*; do
  case $old in "$kdir" | "$cache/initramfs-$abi".*) ;; *) [ ! -e "$old" ] || rm -rf "$old" ;; esac
done
if [ "$(cat "$kdir/stamp" 2>/dev/null)" != "$kernel_stamp" ]; then
  build_kernel_stage
  did=1
fi

initramfs_stamp="$kernel_stamp init=$(sha256sum <"$here/guest-init.sh" | cut -c1-16) \
busybox=$(dpkg-query -W -f='${Version}' busybox-static 2>/dev/null || echo unknown)"
if [ "$(cat "$cache/initramfs-$abi.stamp" 2>/dev/null)" != "$initramfs_stamp" ] ||
  [ ! -f "$cache/initramfs-$abi.cpio.gz" ]; then
  say "building the initramfs"
  build_initramfs
  did=1
fi

# vm_run.sh reads the paths from here.
cat >"$cache/vm.env.tmp" <<EOF
CALIBD_VM_ABI=$abi
CALIBD_VM_KERNEL_IMAGE=$kdir/vmlinuz
CALIBD_VM_INITRAMFS=$cache/initramfs-$abi.cpio.gz
EOF
mv "$cache/vm.env.tmp" "$cache/vm.env"

if [ "$did" = 1 ]; then
  say "ready in $(($(date +%s) - t0)) s: kernel $abi, $(wc -l <"$kdir/modules.load") modules, \
initramfs $(du -h "$cache/initramfs-$abi.cpio.gz" | cut -f1) in $cache"
else
  say "up to date (kernel $abi in $cache)"
fi
