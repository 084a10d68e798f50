# CALIBD_SANITIZERS is a list (address;undefined); applied to every target in the tree.
if(CALIBD_SANITIZERS)
  list(JOIN CALIBD_SANITIZERS "," _calibd_san)
  add_compile_options(-fsanitize=${_calibd_san} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${_calibd_san})
endif()
