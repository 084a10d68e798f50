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
    # With address, undefined's pointer checks (null, alignment, pointer-overflow, object-size)
    # repeat what AddressSanitizer already finds (a bad access, null's included), and they halved
    # the compile of code made of Eigen and Ceres' Jet expressions (clang 14 at -O1: 19 -> 9 s for
    # compressed_box_cost.cpp). The arithmetic checks ASan cannot see stay: signed overflow,
    # shifts, float-to-int casts out of range, division by zero, bounds of arrays, enums, bools.
    add_compile_options(-fno-sanitize=null,alignment,pointer-overflow,object-size)
  endif()
endif()
