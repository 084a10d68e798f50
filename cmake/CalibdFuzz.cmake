# CALIBD_FUZZ (clang only; preset asan): the libFuzzer targets of tests/fuzz/ are built in the
# sanitizer tree beside its unit suites: the code is compiled once for both. The libraries the
# targets call and the targets themselves carry libFuzzer's coverage instrumentation
# (fuzzer-no-link: the instrumentation without libFuzzer's main; tests/fuzz/CMakeLists.txt), so
# the fuzzers see the edges of the production code; the suites, tools and simulator do not (their
# comparisons would each call the instrumentation's hook). UB aborts (CalibdSanitizers.cmake), so
# libFuzzer records it as a crash with its input.
if(CALIBD_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "CALIBD_FUZZ needs clang (libFuzzer): use the preset asan")
  endif()
  if(NOT "address" IN_LIST CALIBD_SANITIZERS)
    message(FATAL_ERROR "CALIBD_FUZZ needs CALIBD_SANITIZERS with address (preset asan)")
  endif()
endif()
