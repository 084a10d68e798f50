# calibd_set_warnings(<target>): the one place that decides our warning flags.
function(calibd_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wconversion -Wshadow -Wnon-virtual-dtor
    -Wno-sign-conversion
    # A unity build (CMAKE_UNITY_BUILD, every preset but debug) compiles a library's files
    # as one, each #included: GCC then warns of every class with a member of a type from a
    # file's anonymous namespace (an Impl's), which is right for one file.
    $<$<AND:$<BOOL:${CMAKE_UNITY_BUILD}>,$<CXX_COMPILER_ID:GNU>>:-Wno-subobject-linkage>)
  if(CALIBD_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
