#!/usr/bin/env bash
# make cross-test: cross-builds core, its tests and calibd-agent for aarch64 (CMake preset
# aarch64, toolchains/aarch64-linux-gnu.cmake) and runs the core suites (label core) under qemu user
# emulation. Installs what it needs first, idempotently: Debian's cross compiler, qemu-user-static
# and mmdebstrap on the host (no amd64 package is changed), and an arm64 sysroot of bookworm's -dev
# packages in ~/.cache/calibd/aarch64-sysroot (about 1.2 GB, several minutes the first time; kept
# while the package list below is unchanged). Like the host's packages, the sysroot is installed
# once per machine, not per checkout: a fresh clone (CI) finds it made. Installing needs root (or
# sudo). JOBS sets the build's parallelism (default 2); arguments go to ctest (e.g. -R Geometry);
# CALIBD_CROSS_BUILD_ONLY=1 stops after the build.
set -euo pipefail
cd "$(dirname "$0")/.."

SYSROOT="${CALIBD_AARCH64_SYSROOT:-${XDG_CACHE_HOME:-$HOME/.cache}/calibd/aarch64-sysroot}"
export CALIBD_AARCH64_SYSROOT="$SYSROOT"
JOBS="${JOBS:-2}"
BUILD=build/aarch64

# Host: the cross compiler, the emulator and the sysroot maker; lcm-gen runs on the host.
HOST_PACKAGES=(cmake ninja-build pkg-config liblcm-bin file
  g++-aarch64-linux-gnu qemu-user-static mmdebstrap)
# Sysroot: what core, drivers, the agent and the tests link, and their dependencies.
SYSROOT_PACKAGES=(libc6-dev libstdc++-12-dev libeigen3-dev libopencv-dev libapriltag-dev
  libceres-dev liblcm-dev libgpiod-dev libyaml-cpp-dev nlohmann-json3-dev zlib1g-dev
  libsystemd-dev libssl-dev liblzf-dev libgtest-dev libglib2.0-dev libjpeg62-turbo-dev
  libpng-dev)
SUITE=bookworm
MIRRORS=("deb http://deb.debian.org/debian bookworm main"
  "deb http://deb.debian.org/debian bookworm-updates main"
  "deb http://deb.debian.org/debian-security bookworm-security main")

SUDO=""
if [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null; then SUDO="sudo"; fi

missing=()
for p in "${HOST_PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "cross-test: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# The sysroot: mmdebstrap's extract variant unpacks the packages and their dependencies without
# running maintainer scripts (which would need arm64 binaries to run; binfmt_misc is not mounted
# here), so what those scripts would have done is done below.
stamp_text="$SUITE ${SYSROOT_PACKAGES[*]} ${MIRRORS[*]}"
# One maker at a time: a second run waits, then finds the sysroot made.
mkdir -p "$(dirname "$SYSROOT")"
exec 9>"$SYSROOT.lock"
flock 9
if [ "$(cat "$SYSROOT/.calibd-sysroot" 2>/dev/null)" != "$stamp_text" ]; then
  echo "cross-test: making the arm64 sysroot in $SYSROOT (downloads about 400 MB)"
  mode=root
  if [ "$(id -u)" -ne 0 ]; then mode=unshare; fi
  rm -rf "$SYSROOT.tmp"
  old_ifs="$IFS"
  IFS=,
  packages="${SYSROOT_PACKAGES[*]}"
  IFS="$old_ifs"
  mmdebstrap --quiet --variant=extract --architectures=arm64 --mode="$mode" \
    --hook-dir=/usr/share/mmdebstrap/hooks/merged-usr \
    --dpkgopt='path-exclude=/usr/share/doc/*' --dpkgopt='path-exclude=/usr/share/man/*' \
    --dpkgopt='path-exclude=/usr/share/locale/*' \
    --include="$packages" "$SUITE" "$SYSROOT.tmp" "${MIRRORS[@]}"
  # Absolute symlinks (libz.so -> /lib/aarch64-linux-gnu/libz.so.1.2.13) would lead into the
  # host's tree: made relative, inside the sysroot.
  while IFS= read -r -d '' link; do
    target="$(readlink "$link")"
    ln -sfn "$(realpath -m -s --relative-to="$(dirname "$link")" "$SYSROOT.tmp$target")" "$link"
  done < <(find "$SYSROOT.tmp/usr" -type l -lname '/*' -print0)
  # update-alternatives did not run: BLAS and LAPACK (Ceres through SuiteSparse) are ATLAS's, the
  # alternative apt chooses on the host too.
  lib="$SYSROOT.tmp/usr/lib/aarch64-linux-gnu"
  for so in libblas.so libblas.so.3 liblapack.so liblapack.so.3; do
    ln -sfn "atlas/$so" "$lib/$so"
  done
  # Ceres's exported target names BLAS and LAPACK by absolute path (/usr/lib/...), Imath its
  # headers: made relative to the package's prefix, which is inside the sysroot.
  grep -rlZ --include='*[Tt]argets.cmake' -E 'INTERFACE_[A-Z_]+ "([^"]*;)?/usr/' "$SYSROOT.tmp/usr" |
    xargs -0 -r sed -i -E '/INTERFACE_[A-Z_]+ "/ s#([";])/usr/#\1${_IMPORT_PREFIX}/#g'
  echo "$stamp_text" >"$SYSROOT.tmp/.calibd-sysroot"
  rm -rf "$SYSROOT"
  mv "$SYSROOT.tmp" "$SYSROOT"
fi
exec 9>&-

cmake --preset aarch64 >/dev/null
cmake --build --preset aarch64 -j "$JOBS"
# CALIBD_CROSS_BUILD_ONLY=1: the build alone (make test runs it beside the release suite).
[ "${CALIBD_CROSS_BUILD_ONLY:-0}" = 1 ] && exit 0

agent="$BUILD/agent/calibd-agent"
kind="$(file -b "$agent")"
case "$kind" in
  *"ARM aarch64"*) echo "cross-test: $agent: ${kind%%, BuildID*}" ;;
  *) echo "cross-test: $agent is not an aarch64 executable: $kind" >&2; exit 1 ;;
esac
# The agent starts on the emulated CPU: its usage text.
qemu-aarch64-static -L "$SYSROOT" "$agent" --help | head -n 3

ctest --preset aarch64 -j "$JOBS" "$@"
