# CALIBD_FUZZ (preset fuzz, clang only): every library is built with AddressSanitizer, UBSan and
# libFuzzer's coverage instrumentation (fuzzer-no-link: the instrumentation without libFuzzer's
# main), so the fuzz targets in tests/fuzz/ see the edges of the production code they call; the
# targets themselves link -fsanitize=fuzzer (tests/fuzz/CMakeLists.txt). UB aborts instead of
# printing and going on, so libFuzzer records it as a crash with its input.
if(CALIBD_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "CALIBD_FUZZ needs clang (libFuzzer): use the preset fuzz")
  endif()
  if(CALIBD_SANITIZERS)
    message(FATAL_ERROR "CALIBD_FUZZ sets its own sanitizers: leave CALIBD_SANITIZERS empty")
  endif()
  add_compile_options(-fsanitize=address,undefined,fuzzer-no-link -fno-sanitize-recover=undefined
    -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()
