# Runs at install time (included by CalibdInstall.cmake's install(CODE)), when CMAKE_INSTALL_PREFIX
# is the prefix of this install (--prefix). Writes the systemd unit with the installed paths and
# installs the config unless one is already there. file(INSTALL) prepends DESTDIR itself.

# A GNUInstallDirs directory made absolute under the install-time prefix. `sysconf`: the
# special case of GNUInstallDirs for etc under the prefixes / and /usr (/etc, not /usr/etc).
function(calibd_full_dir out dir kind)
  string(REGEX REPLACE "/+$" "" prefix "${CMAKE_INSTALL_PREFIX}")
  if(IS_ABSOLUTE "${dir}")
    set(full "${dir}")
  elseif(kind STREQUAL "sysconf" AND (prefix STREQUAL "" OR prefix STREQUAL "/usr"))
    set(full "/${dir}")
  else()
    set(full "${prefix}/${dir}")
  endif()
  set(${out} "${full}" PARENT_SCOPE)
endfunction()

calibd_full_dir(CMAKE_INSTALL_FULL_BINDIR "${CALIBD_BINDIR}" plain)
calibd_full_dir(CMAKE_INSTALL_FULL_SYSCONFDIR "${CALIBD_SYSCONFDIR}" sysconf)
calibd_full_dir(calibd_unit_dir "${CALIBD_UNIT_DIR}" plain)

configure_file("${CALIBD_SOURCE_DIR}/deploy/systemd/calibd.service.in"
  "${CALIBD_BINARY_DIR}/deploy/calibd.service" @ONLY)
file(INSTALL "${CALIBD_BINARY_DIR}/deploy/calibd.service" DESTINATION "${calibd_unit_dir}"
  FILE_PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ)

# Once installed, the config describes this vehicle (its intrinsics, boards, prior): an install
# or an upgrade must not replace it. The default stays readable in share/calibd/calibd.yaml.
set(calibd_config_dir "${CMAKE_INSTALL_FULL_SYSCONFDIR}/calibd")
if(EXISTS "$ENV{DESTDIR}${calibd_config_dir}/calibd.yaml")
  message(STATUS "Keeping: $ENV{DESTDIR}${calibd_config_dir}/calibd.yaml (the default is in "
    "share/calibd/calibd.yaml)")
else()
  file(INSTALL "${CALIBD_SOURCE_DIR}/deploy/config/calibd.yaml"
    DESTINATION "${calibd_config_dir}"
    FILE_PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ)
endif()
