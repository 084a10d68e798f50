# calibd_set_warnings(<target>): the one place that decides our warning flags.
function(calibd_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wconversion -Wshadow -Wnon-virtual-dtor
    -Wno-sign-conversion)
  if(CALIBD_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
