# Read by cpack (CPACK_PROJECT_CONFIG_FILE): a Debian package installs below /usr, where
# linectl's compiled-in configuration folder is /etc/fillet-line.
if(CPACK_GENERATOR STREQUAL "DEB" AND NOT CPACK_PACKAGING_INSTALL_PREFIX STREQUAL "/usr")
  message(FATAL_ERROR "the Debian package needs a build configured with "
                      "-DCMAKE_INSTALL_PREFIX=/usr (this one: ${CPACK_PACKAGING_INSTALL_PREFIX})")
endif()
