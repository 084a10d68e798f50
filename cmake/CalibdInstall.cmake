# Install rules: `make install` or `cmake --install <build> [--prefix P]`, with
# DESTDIR honoured (staging, packaging). GNUInstallDirs layout:
#   bin/calibd-agent, bin/calibd-calibrate, bin/calibd-import, bin/calibd-sim
#                                                             the daemon and the operator tools
#   <sysconfdir>/calibd/calibd.yaml                           the config (never overwritten)
#   share/calibd/calibd.yaml                                  the documented default, for reference
#   lib/systemd/system/calibd.service                         the unit (CALIBD_SYSTEMD_UNIT_DIR)
#   lib/sysusers.d/calibd.conf                                the calibd user, the gpio group
#   lib/udev/rules.d/60-calibd-gpio.rules                     /dev/gpiochip* to the gpio group
# <sysconfdir> is /etc for the prefixes / and /usr, <prefix>/etc otherwise (GNUInstallDirs).
include(GNUInstallDirs)

set(CALIBD_SYSTEMD_UNIT_DIR "lib/systemd/system" CACHE STRING
  "systemd system unit directory: relative to the install prefix, or absolute")
set(CALIBD_SYSUSERS_DIR "lib/sysusers.d" CACHE STRING
  "sysusers.d directory: relative to the install prefix, or absolute")
set(CALIBD_UDEV_RULES_DIR "lib/udev/rules.d" CACHE STRING
  "udev rules directory: relative to the install prefix, or absolute")

install(TARGETS calibd-agent RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
foreach(tool calibd-calibrate calibd-import calibd-sim calibd-tester)
  if(TARGET ${tool})
    install(TARGETS ${tool} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  endif()
endforeach()
install(FILES ${PROJECT_SOURCE_DIR}/deploy/systemd/calibd.sysusers
  DESTINATION ${CALIBD_SYSUSERS_DIR} RENAME calibd.conf)
install(FILES ${PROJECT_SOURCE_DIR}/deploy/udev/60-calibd-gpio.rules
  DESTINATION ${CALIBD_UDEV_RULES_DIR})
install(FILES ${PROJECT_SOURCE_DIR}/deploy/config/calibd.yaml
  DESTINATION ${CMAKE_INSTALL_DATADIR}/calibd)

# The unit's ExecStart and the config's directory depend on the prefix, and `cmake --install
# --prefix P` chooses it after configuration: CMAKE_INSTALL_FULL_* of the configure step would
# be stale. CalibdInstallFiles.cmake resolves them at install time.
install(CODE "
  set(CALIBD_SOURCE_DIR \"${PROJECT_SOURCE_DIR}\")
  set(CALIBD_BINARY_DIR \"${PROJECT_BINARY_DIR}\")
  set(CALIBD_BINDIR \"${CMAKE_INSTALL_BINDIR}\")
  set(CALIBD_SYSCONFDIR \"${CMAKE_INSTALL_SYSCONFDIR}\")
  set(CALIBD_UNIT_DIR \"${CALIBD_SYSTEMD_UNIT_DIR}\")
  include(\"${PROJECT_SOURCE_DIR}/cmake/CalibdInstallFiles.cmake\")
")
