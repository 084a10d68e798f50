# CALIBD_SANITIZERS is a list (address;undefined); applied to every target in the tree.
if(CALIBD_SANITIZERS)
  list(JOIN CALIBD_SANITIZERS "," _calibd_san)
  add_compile_options(-fsanitize=${_calibd_san} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${_calibd_san})
  if("undefined" IN_LIST CALIBD_SANITIZERS AND "address" IN_LIST CALIBD_SANITIZERS)
    # Measured with GCC 12.2 and liblcm 1.3.1: with address+undefined, the vptr check corrupts the
    # `this` of LCM's C++ subscription callback (lcm-cpp-impl.hpp, a pointer-to-member call), and
    # every typed handler crashes; with either sanitizer alone, or without vptr, it runs clean.
    add_compile_options(-fno-sanitize=vptr)
    add_link_options(-fno-sanitize=vptr)
  endif()
endif()
