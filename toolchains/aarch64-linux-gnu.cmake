# Cross build for 64-bit Arm Linux with Debian's cross compiler (g++-aarch64-linux-gnu) against an
# arm64 sysroot of Debian bookworm's -dev packages. toolchains/cross-test.sh makes the sysroot in
# ~/.cache/calibd/aarch64-sysroot (mmdebstrap --variant=extract; $XDG_CACHE_HOME/calibd/... where
# that is set); CALIBD_AARCH64_SYSROOT in the environment points elsewhere. Multiarch (libXXX-dev:arm64 beside the amd64 ones) is not used: apt wanted to
# remove the host's libopencv-dev, libceres-dev and liblcm-dev for it.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

if(DEFINED ENV{CALIBD_AARCH64_SYSROOT})
  set(_calibd_sysroot "$ENV{CALIBD_AARCH64_SYSROOT}")
elseif(DEFINED ENV{XDG_CACHE_HOME})
  set(_calibd_sysroot "$ENV{XDG_CACHE_HOME}/calibd/aarch64-sysroot")
else()
  set(_calibd_sysroot "$ENV{HOME}/.cache/calibd/aarch64-sysroot")
endif()
if(NOT EXISTS "${_calibd_sysroot}/usr/include")
  message(FATAL_ERROR "no arm64 sysroot at ${_calibd_sysroot}: run toolchains/cross-test.sh "
    "(or make cross-test) to make it")
endif()
set(CMAKE_SYSROOT "${_calibd_sysroot}")

# Libraries, headers and CMake packages from the sysroot only; programs (lcm-gen, pkg-config,
# clang-format, python3) from the host.
set(CMAKE_FIND_ROOT_PATH "${_calibd_sysroot}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# pkg-config (pkg_check_modules at configure time) reads only the sysroot's arm64 .pc files and
# prefixes their -I/-L paths with the sysroot.
set(ENV{PKG_CONFIG_PATH} "")
set(ENV{PKG_CONFIG_LIBDIR}
  "${_calibd_sysroot}/usr/lib/aarch64-linux-gnu/pkgconfig:${_calibd_sysroot}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${_calibd_sysroot}")

# No binfmt_misc on the build machines: ctest and gtest_discover_tests start every arm64 program
# through qemu user emulation explicitly, with the sysroot as its library root.
find_program(CALIBD_QEMU_AARCH64 qemu-aarch64-static REQUIRED)
set(CMAKE_CROSSCOMPILING_EMULATOR "${CALIBD_QEMU_AARCH64};-L;${_calibd_sysroot}")
