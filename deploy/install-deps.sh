#!/usr/bin/env bash
# Installs every Debian package that calibd's build, tests and demo need.
# Idempotent and non-interactive: packages already installed are skipped, so a second run
# costs one dpkg query. Run as root (or with sudo available) on Debian bookworm.
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git clang-format
  # LLVM's linker: host builds link with it, several times faster than GNU ld (cmake/CalibdLinker.cmake)
  lld
  # libraries (core, drivers)
  libeigen3-dev libopencv-dev libapriltag-dev libceres-dev
  liblcm-dev liblcm-bin libglib2.0-dev libgpiod-dev
  libyaml-cpp-dev nlohmann-json3-dev zlib1g-dev libsystemd-dev libssl-dev
  # LZF for PCD files' binary_compressed data (drivers/src/pcd_reader.cpp)
  liblzf-dev
  # libjpeg-turbo: the agent decodes JPEG camera frames with it (drivers/src/jpeg_decoder.cpp)
  libjpeg62-turbo-dev
  # libpng: PNG images of recorded folders (drivers/src/recorded_folder.cpp), --debug pictures
  # (drivers/src/png_writer.cpp)
  libpng-dev
  # libFuzzer targets (make fuzz-smoke, tests/fuzz/): clang, whose runtime libraries
  # (libclang_rt.fuzzer, asan, ubsan) come with libclang-rt-14-dev
  clang libclang-rt-14-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # the status frame's DBC decoded by a decoder we did not write (tests/dbc_decode.py)
  python3-canmatrix
  # an independent UDS client over its own user-space ISO-TP (tests/vm/uds_scapy_client.py)
  python3-scapy
  # the HTML report rendered in a real browser, headless (tests/test_html_report_browser.cpp)
  chromium
  # VM tests (tests/vm/): qemu boots Debian's kernel with an initramfs of busybox and modules;
  # gpio-sim.ko is built out of tree against the headers of linux-image-amd64's current ABI (the
  # kernel image and source are fetched into the cache with apt-get download, not installed);
  # the jobs use the host's can-utils, gpiod tools and iproute2 through the shared root
  qemu-system-x86 busybox-static cpio kmod xz-utils linux-headers-amd64
  can-utils gpiod iproute2
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null; then SUDO="sudo"; else
    echo "install-deps: missing packages (${missing[*]}) and not root; run as root" >&2
    exit 1
  fi
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
