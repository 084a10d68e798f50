# Host builds link with LLVM's lld when the compiler accepts it (Debian package lld): the suite
# is about 90 executables, each linking the static libraries with OpenCV, Ceres and the rest;
# linking test_frame_intake (release) takes 0.8 s with GNU ld and 0.2 s with lld. CALIBD_LINKER=
# default keeps the toolchain's own linker; cross builds (toolchains/) keep it always.
set(CALIBD_LINKER "lld" CACHE STRING "Linker for host builds: lld (when usable) or default")
if(CALIBD_LINKER STREQUAL "lld" AND NOT CMAKE_CROSSCOMPILING)
  include(CheckLinkerFlag)
  check_linker_flag(CXX "-fuse-ld=lld" CALIBD_HAVE_LLD)
  if(CALIBD_HAVE_LLD)
    add_link_options(-fuse-ld=lld)
  else()
    message(STATUS "lld not usable: linking with the toolchain's default linker")
  endif()
endif()
